"""The built-in response-file formats of sysid-toolkit, registered as a plugin.

Each format is an engine (:class:`sysid_core.formats.engine.ResponseFormat`); the readers and
writers themselves live in :mod:`sysid_core.formats`.
"""
