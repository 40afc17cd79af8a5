// preCICE perpendicular-flap case (precice/tutorials, perpendicular-flap): a 6 x 4 channel with a
// 0.1 x 1 elastic flap clamped to its floor at x = 0 (../../../shared/reference/perpendicular_flap.md).
// Physical names: cells fluid, solid; facets inlet (x = -3), outlet (x = 3), walls (floor and top),
// clamp (the flap's foot). The fluid-solid interface is found from the cells.
h_far = 0.25;    // element size far from the flap
h_flap = 0.025;  // element size on the flap (4 across its width)
Point(1) = {-3, 0, 0, h_far};  Point(2) = {-0.05, 0, 0, h_flap}; Point(3) = {0.05, 0, 0, h_flap};
Point(4) = {3, 0, 0, h_far};   Point(5) = {3, 4, 0, h_far};       Point(6) = {-3, 4, 0, h_far};
Point(7) = {0.05, 1, 0, h_flap}; Point(8) = {-0.05, 1, 0, h_flap};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 5}; Line(5) = {5, 6}; Line(6) = {6, 1};
Line(7) = {3, 7}; Line(8) = {7, 8}; Line(9) = {8, 2};
Curve Loop(1) = {1, -9, -8, -7, 3, 4, 5, 6}; Plane Surface(1) = {1};   // fluid
Curve Loop(2) = {2, 7, 8, 9};                Plane Surface(2) = {2};   // flap
// grow the elements away from the flap
Field[1] = Distance; Field[1].CurvesList = {7, 8, 9};
Field[2] = Threshold; Field[2].InField = 1; Field[2].SizeMin = h_flap; Field[2].SizeMax = h_far;
Field[2].DistMin = 0.1; Field[2].DistMax = 1.5;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Physical Surface("fluid") = {1};
Physical Surface("solid") = {2};
Physical Curve("inlet") = {6};
Physical Curve("outlet") = {4};
Physical Curve("walls") = {1, 3, 5};
Physical Curve("clamp") = {2};
