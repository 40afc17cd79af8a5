// A 0.2 x 1 x 0.1 box between two plates (3D): the plates y = 0 (bottom) and y = 1 (top), the ends x = 0 (inlet)
// and x = 0.2 (outlet), the sides z = 0 and z = 0.1.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.2, 1, 0.1};  // surfaces: 1 x = 0, 2 x = 0.2, 3 y = 0, 4 y = 1, 5 z = 0, 6 z = 0.1
MeshSize{ PointsOf{ Volume{1}; } } = 0.15;  // level 1: 0.075
Physical Volume("fluid") = {1};
Physical Surface("inlet") = {1};
Physical Surface("outlet") = {2};
Physical Surface("bottom") = {3};
Physical Surface("top") = {4};
Physical Surface("sides") = {5, 6};
