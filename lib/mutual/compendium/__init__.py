"""The compendium's machinery, used by the notebooks, the tests and ``make``; the algorithms never
import it: repository paths (:mod:`.paths`), saving figures and tables (:mod:`.figures`), results
and claims (:mod:`.results`, :mod:`.claims`), the reproduction report (:mod:`.report`) and the
notebook runner (:mod:`.notebooks`)."""

__all__ = []
