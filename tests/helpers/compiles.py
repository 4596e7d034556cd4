"""``pytest --jax-compiles``: how many programs JAX compiled for each test file, and in how long
(``jax_log_compiles``), printed at the end of the run: where the suite's compile time goes. Every
new function, shape or static setting is a compilation; the persistent cache (``.cache/jax-signed``)
turns a repeat in a later process into a quick load, counted too, so run it with an empty
``MUTUAL_CACHE_DIR`` to see a fresh clone's compile time."""

import collections
import logging
import re

import pytest

FINISHED = re.compile(r"Finished XLA compilation of (\S+) in ([0-9.]+) sec")
LOGGER = "jax._src.dispatch"  # the logger that says "Finished XLA compilation of ..."


class CompileCounter(logging.Handler):
    """A pytest plugin and a logging handler: counts the compilations and their seconds per test file."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.where = "(collection and fixtures)"
        self.count, self.seconds, self.programs = collections.Counter(), collections.Counter(), collections.Counter()

    def start(self):
        import jax
        jax.config.update("jax_log_compiles", True)
        logger = logging.getLogger(LOGGER)
        logger.addHandler(self)
        logger.propagate = False  # counted here; not repeated as warnings in every test's captured log

    def emit(self, record):
        found = FINISHED.match(record.getMessage())
        if found:
            self.count[self.where] += 1
            self.seconds[self.where] += float(found.group(2))
            self.programs[found.group(1)] += 1

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(self, item, nextitem):
        self.where = item.nodeid.split("::")[0]
        yield

    def pytest_terminal_summary(self, terminalreporter):
        total, seconds = sum(self.count.values()), sum(self.seconds.values())
        terminalreporter.write_line(f"JAX programs compiled (or loaded from the persistent cache) in this process: {total}, "
                                    f"{seconds:.1f} s (the notebook lane's are its own); the test files that took longest:")
        for where, s in self.seconds.most_common(12):
            terminalreporter.write_line(f"  {s:7.1f} s  {self.count[where]:5d}  {where}")
        terminalreporter.write_line("most compiled programs: " + ", ".join(f"{name} {n}" for name, n in self.programs.most_common(8)))
