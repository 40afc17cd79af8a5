"""Points in a moving mesh: parallel point location and evaluation of the fields (location.py, used by the
probes, the characteristics and the transfer between meshes), the points the characteristics are traced
back from (back_tracking_nodes.py) and the compiled (numba) kernels of both (_kernels.py)."""
