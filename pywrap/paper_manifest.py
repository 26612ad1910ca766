"""Moved to :mod:`remote_trigger.pywrap.paper.manifest`; this name is kept
(the same module object: attributes and monkeypatching are shared)."""
import sys

from .paper import manifest as _module

sys.modules[__name__] = _module
