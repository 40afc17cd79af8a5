"""The mesh that moves with the solid (seed §5.2): the motion of its vertices (motion.py), the solid's gap to
the walls (wall_gap.py), automatic remeshing (remesh.py) and the transfer of fields to a new mesh
(transfer.py). The meshes themselves are built in geometry/."""
