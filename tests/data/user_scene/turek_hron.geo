// The Turek-Hron FSI geometry written by hand as a user's file (tests/test_user_scene.py: its scene equals
// configs/turek_hron_fsi3.yaml). The same OpenCASCADE operations, in the same order and with the same
// options, as the built-in generator (cosserat_fsi/geometry/builtin/turek_hron.py, geometry/_gmsh.py), so that gmsh makes
// the same mesh: channel 2.5 x 0.41, cylinder (0.2, 0.2) r = 0.05 from four quarter arcs, an elastic flag
// [0.249, 0.6] x [0.19, 0.21] with its tip split at A = (0.6, 0.2). Sizes: 0.014 on the cylinder and the
// flag, growing linearly to 0.07 at distance 0.3 (level L: gmsh's MeshSizeFactor 2^-L).
// Names: cells fluid and solid; facets inlet, outlet, walls, cylinder (the interface is found from the cells).
SetFactory("OpenCASCADE");
General.NumThreads = 1;
Mesh.Algorithm = 6;                    // Frontal-Delaunay
Mesh.RandomSeed = 1;
Mesh.ElementOrder = 1;
Mesh.MeshSizeFromPoints = 0;           // the size field alone sets the sizes
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 0;

L = 2.5; H = 0.41;                     // channel
xc = 0.2; yc = 0.2; r = 0.05;          // cylinder
x_tip = 0.6; y0 = 0.19; y1 = 0.21;     // flag

Rectangle(1) = {0, 0, 0, L, H};
Point(5) = {xc, yc, 0};                // the disk's centre, removed once its arcs exist
For k In {0:3}
  Point(6 + k) = {xc + r * Cos(k * Pi / 2), yc + r * Sin(k * Pi / 2), 0};
EndFor
For k In {0:3}
  Circle(5 + k) = {6 + k, 5, 6 + (k + 1) % 4};
EndFor
Curve Loop(2) = {5, 6, 7, 8};
Plane Surface(2) = {2};
Delete { Point{5}; }
// the flag rectangle from the cylinder's centre, its tip split at A; the disk is cut out of it below
Point(10) = {xc, y0, 0}; Point(11) = {x_tip, y0, 0}; Point(12) = {x_tip, yc, 0}; Point(13) = {x_tip, y1, 0};
Point(14) = {xc, y1, 0};
For k In {0:4}
  Line(9 + k) = {10 + k, 10 + (k + 1) % 5};
EndFor
Curve Loop(3) = {9, 10, 11, 12, 13};
Plane Surface(3) = {3};
BooleanDifference{ Surface{1}; Delete; }{ Surface{2, 3}; }       // the fluid: channel minus disk and flag
BooleanDifference{ Surface{3}; Delete; }{ Surface{2}; Delete; }  // the flag minus the disk
BooleanFragments{ Surface{1}; Delete; }{ Surface{3}; Delete; }   // conforming fluid and flag

e = 1e-3;
solid[] = Surface In BoundingBox{xc - e, y0 - e, -e, x_tip + e, y1 + e, e};
fluid[] = Surface{:};
fluid[] -= solid[];
inlet[] = Curve In BoundingBox{-e, -e, -e, e, H + e, e};
outlet[] = Curve In BoundingBox{L - e, -e, -e, L + e, H + e, e};
walls[] = Curve In BoundingBox{-e, -e, -e, L + e, e, e};
walls[] += Curve In BoundingBox{-e, H - e, -e, L + e, H + e, e};
cylinder[] = Curve In BoundingBox{xc - r - e, yc - r - e, -e, xc + r + e, yc + r + e, e};
interface[] = Curve In BoundingBox{xc - e, y0 - e, -e, x_tip + e, y1 + e, e};
interface[] -= cylinder[];             // the flag's free edges (the clamped arc belongs to the cylinder)

Physical Surface("fluid") = {fluid[]};
Physical Surface("solid") = {solid[]};
Physical Curve("inlet") = {inlet[]};
Physical Curve("outlet") = {outlet[]};
Physical Curve("walls") = {walls[]};
Physical Curve("cylinder") = {cylinder[]};

Field[1] = Distance;
Field[1].CurvesList = {cylinder[], interface[]};
If (GMSH_MAJOR_VERSION > 4 || GMSH_MINOR_VERSION >= 11)
  Field[1].Sampling = 400;             // gmsh >= 4.11
Else
  Field[1].NumPointsPerCurve = 400;    // gmsh 4.8 (Debian)
EndIf
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = 0.014;
Field[2].SizeMax = 0.07;
Field[2].DistMin = 0;
Field[2].DistMax = 0.3;
Background Field = 2;
