"""The perceptual study: stimuli, the web app participants answer in, and its analysis."""
