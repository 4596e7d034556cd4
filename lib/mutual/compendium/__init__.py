"""The compendium's machinery, used by the notebooks, the tests and ``make``; the algorithms never
import it: repository paths (:mod:`.paths`), saving figures and tables (:mod:`.figures`), results
and claims (:mod:`.results`, :mod:`.claims`), the reproduction report (:mod:`.report`) and the
notebook runner (:mod:`.notebooks`, its kernels :mod:`.kernel`).

Importing it keeps jsonschema (which nbformat imports) from loading ``rfc3987_syntax``, the optional
checker of its "iri" format, whose grammar takes about 1.4 s to build at every start of a runner, a
kernel, the git filter or the report; nbformat's schema has no "iri" format, so nothing is lost.
"""

import sys

sys.modules.setdefault("rfc3987_syntax", None)  # import rfc3987_syntax now raises ImportError, which jsonschema expects

__all__ = []
