"""The `learned` lifter's training: its network, training pairs drawn from motion capture, and
other proportions and sampled arm motion for those pairs (benchmarks/train_lifter.py)."""
