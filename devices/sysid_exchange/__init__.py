"""Device plugin ``exchange``: a gyro measured by anything that reads and writes files.

The toolkit writes one request per measurement and waits for the answer file: any acquisition
program, a person at the bench, LabVIEW or MATLAB can answer it. See
:class:`sysid_exchange.device.ExchangeDevice` and ``docs/tuning-a-real-gyro.md``.
"""

from __future__ import annotations

from sysid_exchange.device import ExchangeDevice

__all__ = ["ExchangeDevice"]
