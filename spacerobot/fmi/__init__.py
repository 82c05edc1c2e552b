"""The FMUs: their model descriptions and variable tables from the interface, packaged with the
native core's binaries (:mod:`.native`), and the build entry point (:mod:`.build`)."""
