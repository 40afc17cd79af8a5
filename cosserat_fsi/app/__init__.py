"""The application on top of the library: command line (cli), one run of a scene with its outputs (runner),
plots of a finished run (plots), ladders of runs (study) and the case runner that study and the campaigns
share (cases). The library (config, geometry, physics, problem, time_schemes, solvers, mesh, points,
observables, io) never imports from here."""
