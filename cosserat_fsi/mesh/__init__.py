"""The mesh that moves with the solid (seed §5.2): the motion of its vertices (motion.py), the solid's gap to
the walls (wall_gap.py), automatic remeshing (remesh.py), the transfer of fields to a new mesh
(transfer.py) and the run log's count of a solid region's cells across (report.py). The meshes themselves are
built in geometry/."""
