// The 3D flag FSI geometry written by hand as a user's file (tests/test_user_scene.py: its mesh is the built-in
// turek_hron_3d level-0 mesh bit for bit, and its scene gives the numbers of configs/turek_hron_3d_fsi.yaml).
// The same OpenCASCADE operations, in the same order and with the same options, as the built-in generator
// (cosserat_fsi/geometry/builtin/turek_hron_3d.py, geometry/_gmsh.py), so that gmsh makes the same mesh:
// the duct 2.5 x 0.41 x 0.41, a cylinder (axis (0.2, 0.2), radius 0.05) across it in z, an elastic flag
// [0.249, 0.6] x [0.19, 0.21] x [0.105, 0.305] clamped to the cylinder, the middle of its tip
// A = (0.6, 0.2, 0.205) a mesh vertex. Sizes: 0.03 on the cylinder and the flag, growing linearly to 0.15 at
// distance 0.4 (level L: gmsh's MeshSizeFactor 2^-L); Delaunay tetrahedra.
// Names of its own: volumes water and flag (geometry.cells maps them to fluid and solid); surfaces inflow,
// outflow, duct_walls, cylinder (with the face where the flag is clamped). The flag's other five faces are
// the fluid-solid interface, found from the cells: they need no name.
SetFactory("OpenCASCADE");
General.NumThreads = 1;
Mesh.Algorithm = 6;                    // Frontal-Delaunay on the surfaces
Mesh.Algorithm3D = 1;                  // Delaunay in the volumes
Mesh.RandomSeed = 1;
Mesh.ElementOrder = 1;
Mesh.MeshSizeFromPoints = 0;           // the size field alone sets the sizes
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 0;

L = 2.5; H = 0.41; W = 0.41;           // duct
xc = 0.2; yc = 0.2; r = 0.05;          // cylinder
x_tip = 0.6; y0 = 0.19; y1 = 0.21;     // flag
b = 0.2; z0 = (W - b) / 2; z1 = (W + b) / 2;

Box(1) = {0, 0, 0, L, H, W};
Cylinder(2) = {xc, yc, 0, 0, 0, W, r};
Box(3) = {xc, y0, z0, x_tip - xc, y1 - y0, z1 - z0};                  // the flag from the cylinder's axis
flag[] = BooleanDifference{ Volume{3}; Delete; }{ Volume{2}; };        // the flag: the box minus the cylinder
water[] = BooleanDifference{ Volume{1}; Delete; }{ Volume{2}; Delete; };  // the duct minus the cylinder
water[] = BooleanDifference{ Volume{water[]}; Delete; }{ Volume{flag[]}; };  // ... minus the flag
BooleanFragments{ Volume{water[]}; Delete; }{ Volume{flag[]}; Delete; }  // conforming water and flag

e = 1e-3;
flag[] = Volume In BoundingBox{xc - e, y0 - e, z0 - e, x_tip + e, y1 + e, z1 + e};
water[] = Volume{:};
water[] -= flag[];
inflow[] = Surface In BoundingBox{-e, -e, -e, e, H + e, W + e};
outflow[] = Surface In BoundingBox{L - e, -e, -e, L + e, H + e, W + e};
duct_walls[] = Surface In BoundingBox{-e, -e, -e, L + e, e, W + e};             // y = 0
duct_walls[] += Surface In BoundingBox{-e, H - e, -e, L + e, H + e, W + e};     // y = H
duct_walls[] += Surface In BoundingBox{-e, -e, -e, L + e, H + e, e};            // z = 0
duct_walls[] += Surface In BoundingBox{-e, -e, W - e, L + e, H + e, W + e};     // z = W
cylinder[] = Surface In BoundingBox{xc - r - e, yc - r - e, -e, xc + r + e, yc + r + e, W + e};
flag_faces[] = Surface In BoundingBox{xc - e, y0 - e, z0 - e, x_tip + e, y1 + e, z1 + e};
flag_faces[] -= cylinder[];            // the flag's free faces (the clamped one belongs to the cylinder)
tip[] = Surface In BoundingBox{x_tip - e, y0 - e, z0 - e, x_tip + e, y1 + e, z1 + e};

Physical Volume("water") = {water[]};
Physical Volume("flag") = {flag[]};
Physical Surface("inflow") = {inflow[]};
Physical Surface("outflow") = {outflow[]};
Physical Surface("duct_walls") = {duct_walls[]};
Physical Surface("cylinder") = {cylinder[]};

p = newp;
Point(p) = {x_tip, yc, W / 2};         // A, the middle of the flag's tip: a mesh vertex
Point{p} In Surface{tip[0]};

Field[1] = Distance;
If (GMSH_MAJOR_VERSION > 4 || GMSH_MINOR_VERSION >= 9)
  Field[1].SurfacesList = {cylinder[], flag_faces[]};  // gmsh >= 4.9
Else
  Field[1].FacesList = {cylinder[], flag_faces[]};     // gmsh 4.8 (Debian)
EndIf
If (GMSH_MAJOR_VERSION > 4 || GMSH_MINOR_VERSION >= 11)
  Field[1].Sampling = 60;              // gmsh >= 4.11
Else
  Field[1].NumPointsPerCurve = 60;     // gmsh 4.8 (Debian)
EndIf
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = 0.03;
Field[2].SizeMax = 0.15;
Field[2].DistMin = 0;
Field[2].DistMax = 0.4;
Background Field = 2;
