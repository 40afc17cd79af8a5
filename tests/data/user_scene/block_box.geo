// A 0.2 x 0.2 x 0.2 solid block (volume 2) inside a 1 x 0.4 x 0.4 channel (volume 3, the fluid).
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 0.4, 0.4};
Box(2) = {0.4, 0.1, 0.1, 0.2, 0.2, 0.2};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMax = 0.2;
Physical Volume("fluid") = {3};
Physical Volume("solid") = {2};
Physical Surface("inlet") = {Surface In BoundingBox{-0.01, -0.01, -0.01, 0.01, 0.41, 0.41}};
Physical Surface("outlet") = {Surface In BoundingBox{0.99, -0.01, -0.01, 1.01, 0.41, 0.41}};
walls() = Surface In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.01, 0.41};
walls() += Surface In BoundingBox{-0.01, 0.39, -0.01, 1.01, 0.41, 0.41};
walls() += Surface In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.41, 0.01};
walls() += Surface In BoundingBox{-0.01, -0.01, 0.39, 1.01, 0.41, 0.41};
Physical Surface("walls") = {walls()};
