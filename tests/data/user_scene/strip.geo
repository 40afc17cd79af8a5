// A 2 x 1 channel, unstructured triangles of size 0.08 (0.04 on level 1; tests/test_conditions.py):
// inlet x = 0, outlet x = 2, bottom y = 0, top y = 1.
lc = 0.08;
Point(1) = {0, 0, 0, lc}; Point(2) = {2, 0, 0, lc}; Point(3) = {2, 1, 0, lc}; Point(4) = {0, 1, 0, lc};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Physical Surface("fluid") = {1};
Physical Curve("inlet") = {4}; Physical Curve("outlet") = {2};
Physical Curve("bottom") = {1}; Physical Curve("top") = {3};
