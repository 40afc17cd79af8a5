// the channel 1 x 0.4 x 0.4 in two halves sharing the face x = 0.5, the surface group "mid" (inside the domain)
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.5, 0.4, 0.4};
Box(2) = {0.5, 0, 0, 0.5, 0.4, 0.4};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMax = 0.2;
mid() = Surface In BoundingBox{0.49, -0.01, -0.01, 0.51, 0.41, 0.41};
inlet() = Surface In BoundingBox{-0.01, -0.01, -0.01, 0.01, 0.41, 0.41};
outlet() = Surface In BoundingBox{0.99, -0.01, -0.01, 1.01, 0.41, 0.41};
all() = Surface{:};
Physical Volume("fluid") = {1, 2}; Physical Surface("inlet") = {inlet()}; Physical Surface("outlet") = {outlet()};
Physical Surface("mid") = {mid()};
Physical Surface("walls") = {all()};
Physical Surface("walls") -= {inlet(), outlet(), mid()};
