// The 2 x 1 channel of channel.geo in quadrilaterals (tests/test_quadrilaterals.py): inlet x = 0, outlet x = 2, bottom, top.
Point(1) = {0, 0, 0}; Point(2) = {2, 0, 0}; Point(3) = {2, 1, 0}; Point(4) = {0, 1, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Transfinite Curve{1, 3} = 9; Transfinite Curve{2, 4} = 5; Transfinite Surface{1}; Recombine Surface{1};
Physical Surface("fluid") = {1};
Physical Curve("inlet") = {4}; Physical Curve("outlet") = {2};
Physical Curve("bottom") = {1}; Physical Curve("top") = {3};
