"""Time series and the normal form.

``series``       D(t) series: noise level, growth window and rate, saturation
``normal_form``  the paper's 2x2 normal form (Eqs. 8-14): amplitude law, damping

May import: numpy, scipy, :mod:`remote_trigger.analysis.output`, ``errors``.
"""
