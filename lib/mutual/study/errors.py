"""The study subpackage's one exception of its own (every refusal is a ``ValueError``)."""


class DegenerateDataError(ValueError):
    """The data leave a statistic undefined (0/0 or a zero variance); the message says which and why."""
