"""A benchmark for continuous constraint inference that nobody tunes to (an extension of chapters 2-3).

Systems x demonstrators x truths, on data the inference did not generate:

* :mod:`.setups` -- the pendulum, a double integrator, the cart-pole and a car, each as the system
  file a user would write, with the truths hidden from the inference;
* :mod:`.controllers`, :mod:`.safety`, :mod:`.demonstrators` -- hand-written controllers behind a
  look-ahead safety filter, noisy, suboptimal and MPPI demonstrators, integrated with plain RK4;
* :mod:`.cases` -- the cases, their development / held-out split (fixed by a seed) and their
  recordings, written and read as the documented trajectory CSV;
* :mod:`.naive`, :mod:`.kkt`, :mod:`.kkt_search` -- the baselines: the tightest constraint the data
  allow, and the KKT method of Chou, Ozay and Berenson (2019, 2020) as a published peer;
* :mod:`.methods`, :mod:`.scoring`, :mod:`.suite` -- each method behind one small function, one
  scorer for all, and :func:`run_benchmark`, the one call that runs a split (its cases in parallel, on
  :mod:`mutual.parallel`'s Dask runner);
* :mod:`.identifiability` -- how far each true obstacle slides without covering a demonstrated state
  (:func:`slack_table`): what where the demonstrators went leaves open; :func:`recorded_ranges`,
  where they went.

Tune on ``run_benchmark("development")``; run ``"held-out"`` only to report.
"""

from .cases import Case, all_cases, case_csv, case_recording, cases
from .identifiability import centre_slack, recorded_ranges, slack_table
from .scoring import Answer, score
from .suite import METHODS, run_benchmark, summary_table, wins

__all__ = ["METHODS", "Answer", "Case", "all_cases", "case_csv", "case_recording", "cases", "centre_slack", "recorded_ranges",
           "run_benchmark", "score", "slack_table", "summary_table", "wins"]
