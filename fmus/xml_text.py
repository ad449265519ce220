"""Which texts an FMU's model description can carry: XML 1.0 has no way to write most control
characters (not even escaped), so a description or name holding one is refused where it enters
satfmu (a model definition, an artifact), with the character named, before any FMU is built."""
from __future__ import annotations

import re

NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
"""Characters that XML 1.0 cannot carry (tab, line feed and carriage return it can)."""


def xml_problem(text: str) -> str | None:
    """Why ``text`` cannot go into an XML 1.0 document (``"holds U+0000"``), or None.

    Parameters
    ----------
    text : str
        A name, description or other text bound for an XML attribute.

    Returns
    -------
    str or None
        The first character XML 1.0 cannot hold, as ``"holds U+XXXX"``; None if there is none.
    """
    bad = NOT_XML.search(text)
    return None if bad is None else f"holds U+{ord(bad[0]):04X}"
