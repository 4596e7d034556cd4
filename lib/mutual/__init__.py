"""mutual: the algorithms of the thesis "Towards Mutual Understanding between Mortals and
Machines in Motion for Safety" (McPherson, 2022), laid out by its two thrusts (Figure 8.1).

Machines learning human models of safety:

* :mod:`mutual.constraints` -- constraints and chance thresholds from demonstrations (ch. 2-3);
* :mod:`mutual.supervision` -- a supervisor's safe set from their interventions (ch. 4);
* :mod:`mutual.study` -- the teaming study and its statistics (ch. 5).

Robots informing humans through motion:

* :mod:`mutual.motion` -- legible motion (ch. 6) and evident safety (ch. 7).

The two together (Figure 8.1):

* :mod:`mutual.cycle` -- the closing cycle of ch. 8 run end to end: learn, act, show.

:mod:`mutual.compendium` is the machinery of this repository (paths, figures, the report); the
algorithms never import it.

Importing :mod:`mutual` imports no numerical library. It raises XLA:CPU's small-loop threshold
(:mod:`mutual.xla_cpu`), which makes the compiled iLQR, L-BFGS and Riccati loops about 2x faster,
and turns on JAX's persistent compilation cache in the compendium's cache folder
(:mod:`mutual.jax_cache`), so a program compiled once is loaded from disk by later processes.
"""

from .jax_cache import use_persistent_cache
from .xla_cpu import use_small_loop_threshold

__version__ = "0.1.0"

use_small_loop_threshold()
use_persistent_cache()
