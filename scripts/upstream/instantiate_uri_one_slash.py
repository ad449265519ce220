"""pythonfmu 0.7.0: fmi2Instantiate with the resource URI ``file:/abs/path`` crashes (SIGSEGV).

RFC 8089 allows ``file:/path`` (no authority) as well as ``file:///path``; pythonfmu removes only
the ``file://`` prefix (and decodes only ``%20``), so ``file:/abs/path`` becomes the relative path
``file:/abs/path``, which is no folder, and the crash of
``instantiate_missing_resources.py`` follows.

Usage: ``python scripts/upstream/instantiate_uri_one_slash.py [FMU]``; expected today: killed by
SIGSEGV before printing.
"""
import sys

from common import Fmu, report

fmu = Fmu(sys.argv[1:])
uri = fmu.resources.replace("file:///", "file:/", 1)
component = fmu.instantiate(resources=uri.encode())
report(f"fmi2Instantiate({uri!r}) returned {'NULL' if component is None else 'an instance'}; log: {fmu.messages}")
