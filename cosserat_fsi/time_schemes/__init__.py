"""The time schemes (``time.scheme``) and what controls them: one class per scheme behind time_step.py
(characteristics.py with histories.py, ale_bdf.py and generalized_alpha.py with nodal.py, steady.py,
steady_solid.py; schemes.py names them), the variable-step BDF weights and error estimate
(variable_step.py), the step size controller (time_control.py) and the state of a run with its
checkpoint (state.py)."""
