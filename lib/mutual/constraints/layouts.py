"""Ground-truth layouts of the chapter 3 experiment (Section 3.3, Figures 3.1-3.3).

The text fixes how many truths there are and where some lie, not which: the bottom-middle cell on
the straight shot is inferred first (Figure 3.2); F retracts "after the fourth constraint" and the
truth is recovered "by the fifth iteration" (line 710, 714), so four truths are task-relevant; "the
last three constraints in the upper half of the grid" are the blind spot (Figure 3.3); truths are
"states and actions marked off with a red X". A :class:`Layout` is one such ground truth, written on
the 9 x 9 grid (:func:`scaled_cell` moves it to other widths), and
:func:`layout_family` draws the family the chapter 3 scan runs over, by rules fixed before it ran:

* the bottom-middle cell, a state constraint at psi = 0.25 (every layout);
* three more task-relevant truths: ``k`` = 1, 2 or 3 forbidden compass moves and 3 - ``k`` state
  constraints in the lower half off the bottom row (rows 1-3, columns 1-7). The moves are any but E:
  Figure 3.2 explains the demonstrator's avoiding the straight shot (E along the bottom row) by the
  bottom-middle cell, so moving E is allowed;
* three state constraints in the upper half (rows 5-8, any column), the blind spot;
* every cell stays distinct, and in its half, on every grid width of the scan.
"""

from dataclasses import dataclass

import numpy as np

from ..seeds import generator

MOVES_BUT_E = ("NE", "N", "NW", "W", "SW", "S", "SE")
LOWER_ROWS, LOWER_COLUMNS = (1, 2, 3), tuple(range(1, 8))
UPPER_ROWS, UPPER_COLUMNS = (5, 6, 7, 8), tuple(range(9))
FAMILY_WIDTHS = (7, 9, 11, 13)
FAMILY_SEED = 3          # the family's draw, fixed before the scan ran
FAMILY_PER_MOVES = 4     # layouts per number of forbidden moves (1, 2, 3), the chosen one among those with 3


@dataclass(frozen=True)
class Layout:
    """One ground truth besides the bottom-middle cell: ``upper`` (the three upper-half cells), ``lower``
    (further lower-half state constraints) and ``actions`` (forbidden compass moves), cells as (col, row)
    on the 9 x 9 grid."""

    name: str
    upper: tuple
    lower: tuple = ()
    actions: tuple = ()

    def __repr__(self):
        parts = [f"lower {list(self.lower)}"] if self.lower else []
        parts += [f"moves {'/'.join(self.actions)} forbidden"] if self.actions else []
        return f"Layout({self.name}: bottom-middle, {', '.join(parts + [f'upper {list(self.upper)}'])})"

    @property
    def task_relevant(self):
        """How many truths lie off the upper-half blind spot: the bottom-middle cell, ``lower`` and ``actions``."""
        return 1 + len(self.lower) + len(self.actions)


CHOSEN_LAYOUT = Layout("four", upper=((2, 6), (4, 7), (6, 5)), actions=("NW", "W", "SW"))
# the earlier layouts: three task-relevant truths, which the text's count rules out; shown beside the result
EARLIER_LAYOUTS = (Layout("first", upper=((2, 6), (4, 7), (6, 5)), actions=("NW", "SW")),
                   Layout("second", upper=((2, 6), (4, 7), (6, 6)), actions=("NW", "SW")))
LAYOUTS = {layout.name: layout for layout in (CHOSEN_LAYOUT,) + EARLIER_LAYOUTS}


def scaled_cell(cell, width):
    """A cell of the 9 x 9 layout moved onto a ``width`` x ``width`` grid (each coordinate scaled by
    (width - 1) / 8 and rounded half up): the same places relative to the grid, for the grid-size scan."""
    return tuple(int(np.floor(v * (width - 1) / 8 + 0.5)) for v in cell)


def fits(layout, widths=FAMILY_WIDTHS):
    """Whether ``layout`` keeps its cells distinct, the lower ones below the middle row and off the bottom
    row, and the upper ones above the middle row, on every width of ``widths``."""
    for w in widths:
        mid = (w - 1) // 2
        cells = [scaled_cell((4, 0), w)] + [scaled_cell(c, w) for c in layout.lower + layout.upper]
        lower = [scaled_cell(c, w)[1] for c in layout.lower]
        upper = [scaled_cell(c, w)[1] for c in layout.upper]
        if len(set(cells)) != len(cells) or not all(0 < r < mid for r in lower) or not all(r > mid for r in upper):
            return False
    return True


def _draw(rng, moves, name):
    actions = tuple(sorted(rng.choice(MOVES_BUT_E, moves, replace=False), key=MOVES_BUT_E.index))
    lower_cells = [(c, r) for r in LOWER_ROWS for c in LOWER_COLUMNS]
    upper_cells = [(c, r) for r in UPPER_ROWS for c in UPPER_COLUMNS]
    lower = tuple(sorted(lower_cells[i] for i in rng.choice(len(lower_cells), 3 - moves, replace=False)))
    upper = tuple(sorted(upper_cells[i] for i in rng.choice(len(upper_cells), 3, replace=False)))
    return Layout(name, upper, lower, actions)


def layout_family(widths=FAMILY_WIDTHS, per_moves=FAMILY_PER_MOVES, seed=FAMILY_SEED):
    """The layouts the chapter 3 scan runs over (module docstring): :data:`CHOSEN_LAYOUT` first, then
    ``per_moves`` layouts with each number of forbidden moves (1, 2, 3; the chosen one counts among those
    with 3), drawn in that order from generator ``seed``, redrawing any that does not :func:`fit` the
    ``widths``. Names: "L<moves>-<i>"."""
    rng, family = generator(seed, "seed"), [CHOSEN_LAYOUT]
    for moves in (1, 2, 3):
        count = 1 if moves == 3 else 0
        while count < per_moves:
            layout = _draw(rng, moves, f"L{moves}-{count}")
            if fits(layout, widths) and all((layout.lower, layout.upper, layout.actions)
                                            != (f.lower, f.upper, f.actions) for f in family):
                family.append(layout)
                count += 1
    return family
