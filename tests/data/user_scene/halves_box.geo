// A 1 x 0.4 x 0.4 channel (3D) in two halves that share the face x = 0.5, the surface group "mid" (inside the
// domain); the plates y = 0 and y = 0.4, the sides z = 0 and z = 0.4.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.5, 0.4, 0.4};
Box(2) = {0.5, 0, 0, 0.5, 0.4, 0.4};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
MeshSize{ PointsOf{ Volume{:}; } } = 0.2;
Physical Volume("fluid") = {1, 2};
Physical Surface("inlet") = {Surface In BoundingBox{-0.01, -0.01, -0.01, 0.01, 0.41, 0.41}};
Physical Surface("outlet") = {Surface In BoundingBox{0.99, -0.01, -0.01, 1.01, 0.41, 0.41}};
Physical Surface("mid") = {Surface In BoundingBox{0.49, -0.01, -0.01, 0.51, 0.41, 0.41}};
plates() = Surface In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.01, 0.41};
plates() += Surface In BoundingBox{-0.01, 0.39, -0.01, 1.01, 0.41, 0.41};
Physical Surface("plates") = {plates()};
sides() = Surface In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.41, 0.01};
sides() += Surface In BoundingBox{-0.01, -0.01, 0.39, 1.01, 0.41, 0.41};
Physical Surface("sides") = {sides()};
