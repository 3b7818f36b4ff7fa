"""Running a scene: the chunked driver, the file-writing runner, the CLI, ensembles
(on one host and over processes)."""
