// A 1 x 0.4 x 0.4 channel (3D): the plates y = 0 and y = 0.4, the sides z = 0 and z = 0.4.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 0.4, 0.4};  // surfaces: 1 x = 0, 2 x = 1, 3 y = 0, 4 y = 0.4, 5 z = 0, 6 z = 0.4
Mesh.MeshSizeMax = 0.2;
Physical Volume("fluid") = {1};
Physical Surface("inlet") = {1};
Physical Surface("outlet") = {2};
Physical Surface("plates") = {3, 4};
Physical Surface("sides") = {5, 6};
