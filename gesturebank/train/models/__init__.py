"""The speech-to-motion models, one module each (the contract they keep is `train.contract`):
the dissertation's MLP and LSTM (`dissertation`), the seeds' aud2motion, aud2pose,
aud2repr2pose, blstm, cvae and dcccae, their shared layers (`layers`), and the helpers that build,
describe and rebuild any registered model from its config sections (`build`)."""
