"""The ``visa`` device: a frequency-response analyzer and a DC bias source over PyVISA,
their SCPI commands from instrument profiles, and a simulated instrument pair
(``sysid instrument-sim``)."""

from sysid_visa.device import VisaDevice

__all__ = ["VisaDevice"]
