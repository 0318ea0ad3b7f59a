"""Response files and manifests: the formats a lab's data come in, as engines.

Lives here: what a format engine declares and how a file finds its engine (:mod:`.engine`; the
engines themselves register through the plugin system, the built-in ones from the
``sysid_formats`` plugin), reading and writing one sweep per file through them
(:mod:`.sweepfiles`), the built-in formats' readers and writers (own CSV :mod:`.csvsweep`,
Touchstone :mod:`.touchstone`, MATLAB :mod:`.matsweep` and :mod:`.mat73`, netCDF
:mod:`.netcdf`), the one reader of text files (:mod:`.textfile`), instruments' text exports read
with column maps (:mod:`.columnmap`, :mod:`.columnsweep`, :mod:`.columnguess`), and manifests of
measured experiments with their exports (:mod:`.manifest`, :mod:`.export`).

May import: :mod:`sysid_core.errors`, :mod:`sysid_core.data` (the data set these files become)
and :mod:`sysid_core.plugin` (the registry the engines come from).
"""
