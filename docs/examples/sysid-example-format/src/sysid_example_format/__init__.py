"""An example response-file format for sysid-toolkit: one sweep per numpy ``.npz`` archive."""

from sysid_example_format.engine import NpzFormat

__all__ = ["NpzFormat"]
