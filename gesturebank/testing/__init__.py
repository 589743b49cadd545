"""Code for tests and benchmarks, not the product: nothing in the toolkit imports this package.

Each module makes one kind of test input (e.g. `footage`: real takes of the kinds users bring,
derived from the sample media, with real speech as their audio track).
"""
