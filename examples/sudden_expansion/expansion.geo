// A channel with a sudden expansion (a backward-facing step, expansion ratio 2), for
// examples/sudden_expansion: the inlet channel 0 <= x <= 2, 1 <= y <= 2 opens at x = 2 into the channel
// 2 <= x <= 14, 0 <= y <= 2. Physical names: fluid; inlet, outlet, walls (top and the inlet channel's
// floor), step (the step's face x = 2 and the floor behind it: the recirculation's walls).
h = 0.1;        // element size away from the corner (level 0; each level halves it)
hc = 0.02;      // at the step's corner (2, 1), where the flow separates
Point(1) = {0, 1, 0, h};  Point(2) = {2, 1, 0, hc}; Point(3) = {2, 0, 0, h / 2};
Point(4) = {14, 0, 0, h}; Point(5) = {14, 2, 0, h}; Point(6) = {0, 2, 0, h};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 5}; Line(5) = {5, 6}; Line(6) = {6, 1};
Curve Loop(1) = {1, 2, 3, 4, 5, 6};
Plane Surface(1) = {1};
Physical Surface("fluid") = {1};
Physical Curve("inlet") = {6};
Physical Curve("outlet") = {4};
Physical Curve("walls") = {1, 5};
Physical Curve("step") = {2, 3};
