"""cosserat-fsi: monolithic Eulerian FSI of an elastic body in a Cosserat (micropolar) fluid.

Implements the scheme of Hussain, Khan & Liu (seed paper, eqs. 29-32) on FEniCSx.
"""

__version__ = "0.1.0"
