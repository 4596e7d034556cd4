"""What several test files share: dense references, tiny problems small enough to enumerate, simulated
inputs and the placeholders of the bad-input tables. Tests import them as ``helpers.<module>`` (pytest's
``pythonpath`` puts ``tests/`` on the path)."""
