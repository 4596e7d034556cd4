"""A benchmark for continuous constraint inference that nobody tunes to (an extension of chapters 2-3).

Systems x demonstrators x truths, on data the inference did not generate:

* :mod:`.setups` -- the pendulum, a double integrator, the cart-pole and a car, each as the system
  file a user would write, with the truths hidden from the inference;
* :mod:`.controllers`, :mod:`.safety`, :mod:`.demonstrators` -- hand-written controllers behind a
  look-ahead safety filter, noisy, suboptimal and MPPI demonstrators, integrated with plain RK4;
* :mod:`.cases` -- the cases, their development / held-out split (fixed by a seed) and their
  recordings, written and read as the documented trajectory CSV.
"""

from .cases import Case, all_cases, case_csv, case_recording, cases

__all__ = ["Case", "all_cases", "case_csv", "case_recording", "cases"]
