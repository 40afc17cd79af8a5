"""The application on top of the library: command line (cli), one run of a scene with its outputs (runner),
plots of a finished run (plots) and ladders of runs (study). The library (config, geometry, physics, scheme,
observables, io) never imports from here."""
