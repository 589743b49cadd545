"""Code for tests and benchmarks, not the product: nothing in the toolkit imports this package.

Each module makes one kind of test input: `clips` (datasets of synthetic clips), `corrupt`
(corrupted copies of real clips, for the QC), `speech_motion` (a dataset whose motion follows
its speech, for the trainer), `tiny_models` (model folders of tiny random-weight models, for
live mode), `mocap` (a real BVH stretch with real speech beside it), `inline` (an executor
that runs in the caller's thread, in place of a thread pool);
`naoqi_server` stands in for a robot, and `browser` drives headless Chromium for page
tests. Real footage of the kinds users bring is `gesturebank.footage`.
"""
