"""The sizes a system file asks for, read before the file is loaded, so that ``infer-continuous`` and
``simulate`` refuse a request beyond the machine (:mod:`mutual.budget`) before anything is allocated:
loading itself builds the grid, and ``[state] cells = [10**9, 10**9]`` would ask for 7.45 GiB per
coordinate there. Only whole numbers are read here; a value of the wrong kind is left to
:func:`mutual.constraints.continuous.load_system`, which names the key. Defaults are the loader's.
"""

from .. import budget
from . import common


def _whole(value):
    return isinstance(value, int) and not isinstance(value, bool) and value >= 1


def _table(mapping, name):
    value = mapping.get(name, {})
    return value if isinstance(value, dict) else {}


def declared(path, cells_option=None):
    """``(mapping, sizes)``: the file's raw mapping and the sizes it declares (cells with ``--cells`` applied,
    controls, samples, scheme, horizon, substeps), or ``sizes = None`` when a size is not a whole number."""
    from ..inputs import read_toml
    with common.about(path):
        mapping = read_toml(path)
    state, time = _table(mapping, "state"), _table(mapping, "time")
    disc, control = _table(mapping, "discretization"), _table(mapping, "control")
    cells = state.get("cells")
    if cells_option:
        try:
            override = [int(c) for c in cells_option.split(",")]
        except ValueError:
            raise common.InputError(f"--cells {cells_option}: must be integers separated by commas") from None
        cells = override * (len(cells) if isinstance(cells, list) and len(override) == 1 else 1)
    values = control.get("values")
    sizes = {"cells": cells, "controls": len(values) if isinstance(values, list) else None,
             "samples": disc.get("samples", 16), "horizon": time.get("horizon"), "substeps": time.get("substeps", 4),
             "scheme": disc.get("scheme", "sample")}
    whole = isinstance(cells, list) and cells and all(_whole(c) for c in cells) and \
        all(_whole(sizes[k]) for k in ("controls", "samples", "horizon", "substeps"))
    return mapping, (sizes if whole else None)


def check_inference(path, args):
    """Refuse an ``infer-continuous`` request beyond the limits (before the system file is loaded)."""
    mapping, s = declared(path, args.cells)
    if s is not None:
        cand = _table(mapping, "candidates")
        families = args.families.split(",") if args.families else cand.get("families", ["bound"])
        families = [str(f).strip() for f in families] if isinstance(families, list) else ["bound"]
        budget.check(budget.continuous_inference(
            s["cells"], s["controls"], s["samples"], s["horizon"], s["scheme"], s["substeps"], families,
            cand.get("every", 2) if _whole(cand.get("every", 2)) else 2,
            len(cand["radii"]) if isinstance(cand.get("radii"), list) else 3,
            len(cand["half_widths"]) if isinstance(cand.get("half_widths"), list) else 2))


def check_simulation(path, args):
    """Refuse a ``simulate --system`` request beyond the limits (before the system file is loaded)."""
    mapping, s = declared(path)
    if s is None:
        return
    sim = _table(mapping, "simulate")
    n = args.n if args.n is not None else sim.get("n", 20)
    kind = args.demonstrator or sim.get("demonstrator", "soft")
    fine = sim.get("fine_cells", [3 * c for c in s["cells"]])
    record, plans, plan_steps = (sim.get(k, d) for k, d in (("record_every", 1), ("samples", 256), ("plan_steps", 20)))
    if not all(_whole(v) for v in (n, record, plans, plan_steps)):
        return
    if kind == "soft" and isinstance(fine, list) and all(_whole(c) for c in fine):
        budget.check(budget.soft_demonstrator(fine, s["controls"], s["horizon"], s["substeps"]))
    mppi = kind == "mppi"
    budget.check(budget.rollouts(n, s["horizon"], len(s["cells"]), s["controls"], s["substeps"], record,
                                 plans * mppi, plan_steps * mppi))
