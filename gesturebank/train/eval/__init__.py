"""Scoring trained models: the dissertation's measures (`metrics`), the field's (`fgd`, `beats`),
a split's inputs for them (`field`), one model (`evaluate`) and several side by side
(`compare`)."""
