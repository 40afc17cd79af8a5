// A 2 x 1 channel with a 0.2 x 0.4 solid block standing on its floor (tests/test_user_scene.py)
h = 0.1;
Point(1) = {0, 0, 0, h}; Point(2) = {0.8, 0, 0, h}; Point(3) = {1.0, 0, 0, h}; Point(4) = {2, 0, 0, h};
Point(5) = {2, 1, 0, h}; Point(6) = {0, 1, 0, h}; Point(7) = {1.0, 0.4, 0, h}; Point(8) = {0.8, 0.4, 0, h};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 5}; Line(5) = {5, 6}; Line(6) = {6, 1};
Line(7) = {3, 7}; Line(8) = {7, 8}; Line(9) = {8, 2};
Curve Loop(1) = {1, -9, -8, -7, 3, 4, 5, 6}; Plane Surface(1) = {1};
Curve Loop(2) = {2, 7, 8, 9}; Plane Surface(2) = {2};
Physical Surface("fluid") = {1};
Physical Surface("solid") = {2};
Physical Curve("inlet") = {6};
Physical Curve("outlet") = {4};
Physical Curve("walls") = {1, 3, 5};
Physical Curve("clamp") = {2};
