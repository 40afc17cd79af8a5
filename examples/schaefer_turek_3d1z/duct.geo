// Schaefer-Turek 3D-1Z drawn by hand: the square duct [0, 2.5] x [0, 0.41]^2 minus a cylinder of diameter
// 0.1 whose axis (x, y) = (0.5, 0.2) runs along z. Physical names of its own: the volume "fluid"; the
// surfaces "inflow" (x = 0), "outflow" (x = 2.5), "duct_walls" (y = 0, y = 0.41, z = 0, z = 0.41) and
// "obstacle" (the cylinder). The two pressure probes of the benchmark, (0.45, 0.2, 0.205) and
// (0.55, 0.2, 0.205), are mesh vertices on the cylinder.
//
// The mesh is graded: size h_cyl on the cylinder, growing linearly with the distance from it to h_far at
// distance d_far; h_wake in the box behind the cylinder (x < x_wake). Each size is a DefineConstant: a
// file that sets it and then Includes this one changes it, e.g. `h_cyl = 0.004; Include "duct.geo";`
// (campaigns/schaefer_turek_3d1z_user.py writes such files); geometry.level halves every size per level.
DefineConstant[
  h_cyl = {0.006, Name "size on the cylinder"},
  h_far = {0.04, Name "size far from the cylinder"},
  d_far = {0.3, Name "distance from the cylinder where h_far is reached"},
  h_wake = {0.02, Name "size in the wake box"},
  x_wake = {1.0, Name "end of the wake box"}
];
SetFactory("OpenCASCADE");
General.NumThreads = 1;
Mesh.Algorithm = 6;                    // Frontal-Delaunay on the surfaces
Mesh.Algorithm3D = 1;                  // Delaunay in the volume
Mesh.RandomSeed = 1;
Mesh.ElementOrder = 1;
Mesh.MeshSizeFromPoints = 0;           // the size fields alone set the sizes
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.Optimize = 1;

L = 2.5; H = 0.41;                     // duct
xc = 0.5; yc = 0.2; r = 0.05;          // cylinder

Box(1) = {0, 0, 0, L, H, H};
Cylinder(2) = {xc, yc, 0, 0, 0, H, r};
Rotate {{0, 0, 1}, {xc, yc, 0}, Pi / 2} { Volume{2}; }  // its seam to the top (x, y) = (0.5, 0.25), off the probes
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };

e = 1e-3;
inflow[] = Surface In BoundingBox{-e, -e, -e, e, H + e, H + e};
outflow[] = Surface In BoundingBox{L - e, -e, -e, L + e, H + e, H + e};
obstacle[] = Surface In BoundingBox{xc - r - e, yc - r - e, -e, xc + r + e, yc + r + e, H + e};
duct_walls[] = Surface In BoundingBox{-e, -e, -e, L + e, H + e, H + e};
duct_walls[] -= {inflow[], outflow[], obstacle[]};

// the pressure probes as mesh vertices on the cylinder
p1 = newp; Point(p1) = {xc - r, yc, H / 2};
p2 = newp; Point(p2) = {xc + r, yc, H / 2};
Point{p1, p2} In Surface{obstacle[0]};

Physical Volume("fluid") = {3};
Physical Surface("inflow") = {inflow[]};
Physical Surface("outflow") = {outflow[]};
Physical Surface("duct_walls") = {duct_walls[]};
Physical Surface("obstacle") = {obstacle[]};

Field[1] = Distance;
If (GMSH_MAJOR_VERSION > 4 || GMSH_MINOR_VERSION >= 9)
  Field[1].SurfacesList = {obstacle[]};
Else
  Field[1].FacesList = {obstacle[]};   // gmsh 4.8
EndIf
If (GMSH_MAJOR_VERSION > 4 || GMSH_MINOR_VERSION >= 11)
  Field[1].Sampling = 100;
Else
  Field[1].NumPointsPerCurve = 100;    // gmsh 4.8
EndIf
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = h_cyl;
Field[2].SizeMax = h_far;
Field[2].DistMin = 0;
Field[2].DistMax = d_far;
Field[3] = Box;
Field[3].VIn = h_wake;
Field[3].VOut = h_far;
Field[3].XMin = xc; Field[3].XMax = x_wake;
Field[3].YMin = yc - 2 * r; Field[3].YMax = yc + 2 * r;
Field[3].ZMin = 0; Field[3].ZMax = H;
Field[4] = Min;
Field[4].FieldsList = {2, 3};
Background Field = 4;
