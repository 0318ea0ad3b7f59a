"""Plugins: the hook specifications, the registry that loads them, and their interfaces.

Lives here: the hooks and the ``hookspec`` / ``hookimpl`` markers (:mod:`.spec`), the
interfaces a plugin implements (:mod:`.interfaces`), the checking of a factory's options
(:mod:`.options`) and the registry (:mod:`.registry`).

May import: everything below it (errors, data, conic, model, identification, tuning, device).
"""
