"""Moved to :mod:`remote_trigger.pywrap.paper.report_fig5`; this name is kept
(the same module object: attributes and monkeypatching are shared)."""
import sys

from .paper import report_fig5 as _module

sys.modules[__name__] = _module
