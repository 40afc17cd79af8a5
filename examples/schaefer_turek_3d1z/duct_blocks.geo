// Schaefer-Turek 3D-1Z drawn by hand as a block-structured mesh: the duct [0, 2.5] x [0, 0.41]^2 minus the
// cylinder of diameter 0.1 whose axis (x, y) = (0.5, 0.2) runs along z. The plane z = H/2 is cut into
// transfinite quadrilateral blocks (an O-grid of four blocks around the cylinder, a frame around it, a wake block
// and an outflow block), each lower block the mirror image of its upper twin; the blocks are extruded in layers
// to z = 0 and z = H (prisms, which gmsh splits into tetrahedra). Physical names of its own, as duct.geo: the
// volume "fluid"; the surfaces "inflow", "outflow", "duct_walls", "obstacle". The pressure probes
// (0.45, 0.2, 0.205) and (0.55, 0.2, 0.205) are mesh vertices on the cylinder (z = H/2 is a layer plane).
//
// Each count and growth is a DefineConstant: `n_q = 24; Include "duct_blocks.geo";` changes one
// (campaigns/schaefer_turek_3d1z_user.py writes such files). The defaults are the ladder's most accurate mesh
// (docs/validation.md, "3D-1Z as a user's .geo"): 94,080 tetrahedra, 423,948 unknowns.
DefineConstant[
  n_q = {16, Name "segments per quarter of the cylinder (even)"},
  n_r = {8, Name "radial segments around the cylinder"},
  q_r = {1.2, Name "radial growth"},
  n_y = {4, Name "segments between the walls y = 0, H and the cylinder's block"},
  q_y = {1.2, Name "growth from the walls"},
  n_in = {6, Name "segments from the inflow to the cylinder's block"},
  q_in = {1.15, Name "growth towards the inflow"},
  x_w = {1.1, Name "end of the wake block"},
  n_w = {8, Name "segments in the wake block"},
  q_w = {1.08, Name "growth in the wake block"},
  n_out = {6, Name "segments from the wake block to the outflow"},
  q_out = {1.1, Name "growth towards the outflow"},
  dz0 = {0.0107, Name "first layer at the z walls"},
  dz_max = {0.035, Name "thickest layer"},
  dz_mid = {0.04, Name "layers at the middle plane z = H / 2"},
  q_z = {1.5, Name "growth of the layers"},
  alternate = {0, Name "alternate diagonals"}
];
General.NumThreads = 1;
Mesh.RandomSeed = 1;
L = 2.5; H = 0.41; xc = 0.5; yc = 0.2; r = 0.05; a = 0.1;
n_q = 2 * Ceil(n_q / 2); h_q = n_q / 2;
// the frame's points P_i_j = (xs[i], ys[j]); row j = 2 is the cylinder's plane y = yc
xs[] = {0, xc - a, xc + a, x_w, L}; ys[] = {0, yc - a, yc, yc + a, H};
For i In {0 : 4}
  For j In {0 : 4}
    P~{i}~{j} = newp; Point(P~{i}~{j}) = {xs[i], ys[j], H / 2};
  EndFor
EndFor
For i In {0 : 3}
  For j In {0 : 4}
    If (!(i == 1 && j == 2))
      X~{i}~{j} = newl; Line(X~{i}~{j}) = {P~{i}~{j}, P~{i+1}~{j}};
    EndIf
  EndFor
EndFor
For i In {0 : 4}
  For j In {0 : 3}
    Y~{i}~{j} = newl; Line(Y~{i}~{j}) = {P~{i}~{j}, P~{i}~{j+1}};
  EndFor
EndFor
// the cylinder: points at 0, 45, 135, 180, 225, 315 degrees, arcs between them, radial lines outwards
O = newp; Point(O) = {xc, yc, H / 2};
angles[] = {0, 45, 135, 180, 225, 315};
For k In {0 : 5}
  C~{k} = newp; Point(C~{k}) = {xc + r * Cos(angles[k] * Pi / 180), yc + r * Sin(angles[k] * Pi / 180), H / 2};
EndFor
For k In {0 : 5}
  A~{k} = newl; Circle(A~{k}) = {C~{k}, O, C~{(k + 1) % 6}};   // A_k from angles[k] to angles[k + 1]
EndFor
R~{0} = newl; Line(R~{0}) = {C~{0}, P~{2}~{2}};
R~{1} = newl; Line(R~{1}) = {C~{1}, P~{2}~{3}};
R~{2} = newl; Line(R~{2}) = {C~{2}, P~{1}~{3}};
R~{3} = newl; Line(R~{3}) = {C~{3}, P~{1}~{2}};
R~{4} = newl; Line(R~{4}) = {C~{4}, P~{1}~{1}};
R~{5} = newl; Line(R~{5}) = {C~{5}, P~{2}~{1}};
// node distributions (a curve with a minus sign: its progression runs from its end)
Transfinite Curve{A~{1}, A~{4}, X~{1}~{1}, X~{1}~{3}} = n_q + 1;
Transfinite Curve{A~{0}, A~{2}, A~{3}, A~{5}} = h_q + 1;
For k In {0 : 5}
  Transfinite Curve{R~{k}} = n_r + 1 Using Progression q_r;
EndFor
For j In {0 : 4}
  Transfinite Curve{-X~{0}~{j}} = n_in + 1 Using Progression q_in;
  Transfinite Curve{X~{2}~{j}} = n_w + 1 Using Progression q_w;
  Transfinite Curve{X~{3}~{j}} = n_out + 1 Using Progression q_out;
EndFor
Transfinite Curve{X~{1}~{0}, X~{1}~{4}} = n_q + 1;
For i In {0 : 4}
  Transfinite Curve{Y~{i}~{0}} = n_y + 1 Using Progression q_y;
  Transfinite Curve{-Y~{i}~{3}} = n_y + 1 Using Progression q_y;
  Transfinite Curve{Y~{i}~{1}, Y~{i}~{2}} = h_q + 1;
EndFor
// blocks; each lower block (y < yc) lists its corners as the mirror images of its upper twin's, so that
// the two are meshed as mirror images
surfaces[] = {};
For i In {0 : 3}
  For j In {0 : 3}
    If (!(i == 1 && (j == 1 || j == 2)))
      c = newll; Curve Loop(c) = {X~{i}~{j}, Y~{i+1}~{j}, -X~{i}~{j+1}, -Y~{i}~{j}};
      t = news; Plane Surface(t) = {c}; surfaces[] += t;
      If (j >= 2)
        Transfinite Surface{t} = {P~{i}~{j}, P~{i+1}~{j}, P~{i+1}~{j+1}, P~{i}~{j+1}};
      Else
        Transfinite Surface{t} = {P~{i}~{j+1}, P~{i+1}~{j+1}, P~{i+1}~{j}, P~{i}~{j}};
      EndIf
    EndIf
  EndFor
EndFor
c = newll; Curve Loop(c) = {A~{0}, R~{1}, -Y~{2}~{2}, -R~{0}};       // right, upper
t = news; Plane Surface(t) = {c}; surfaces[] += t; Transfinite Surface{t} = {C~{0}, C~{1}, P~{2}~{3}, P~{2}~{2}};
c = newll; Curve Loop(c) = {-A~{5}, R~{5}, Y~{2}~{1}, -R~{0}};        // right, lower
t = news; Plane Surface(t) = {c}; surfaces[] += t; Transfinite Surface{t} = {C~{0}, C~{5}, P~{2}~{1}, P~{2}~{2}};
c = newll; Curve Loop(c) = {A~{1}, R~{2}, X~{1}~{3}, -R~{1}};        // top
t = news; Plane Surface(t) = {c}; surfaces[] += t; Transfinite Surface{t} = {C~{1}, C~{2}, P~{1}~{3}, P~{2}~{3}};
c = newll; Curve Loop(c) = {-A~{4}, R~{4}, X~{1}~{1}, -R~{5}};       // bottom
t = news; Plane Surface(t) = {c}; surfaces[] += t; Transfinite Surface{t} = {C~{5}, C~{4}, P~{1}~{1}, P~{2}~{1}};
c = newll; Curve Loop(c) = {A~{2}, R~{3}, Y~{1}~{2}, -R~{2}};        // left, upper
t = news; Plane Surface(t) = {c}; surfaces[] += t; Transfinite Surface{t} = {C~{2}, C~{3}, P~{1}~{2}, P~{1}~{3}};
c = newll; Curve Loop(c) = {-A~{3}, R~{3}, -Y~{1}~{1}, -R~{4}};      // left, lower
t = news; Plane Surface(t) = {c}; surfaces[] += t; Transfinite Surface{t} = {C~{4}, C~{3}, P~{1}~{2}, P~{1}~{1}};
If (alternate)
  Transfinite Surface{surfaces[]} Alternate;
EndIf
// layers in z, listed from the middle plane z = H / 2 to a wall: dz_mid at the middle and dz0 at the wall,
// each growing by q_z up to dz_max, layers of dz_max between; scaled to fill H / 2 exactly
wall[] = {}; dz = dz0;
For i In {1 : 100}
  If (dz < dz_max)
    wall[] += dz; dz *= q_z;
  EndIf
EndFor
mid[] = {}; dz = dz_mid;
For i In {1 : 100}
  If (dz < dz_max)
    mid[] += dz; dz *= q_z;
  EndIf
EndFor
sw = 0; sm = 0;
For i In {0 : #wall[] - 1}
  sw += wall[i];
EndFor
For i In {0 : #mid[] - 1}
  sm += mid[i];
EndFor
n_fill = Max(0, Round((H / 2 - sw - sm) / dz_max));
hz[] = {};
For i In {0 : #mid[] - 1}
  hz[] += mid[i];
EndFor
For i In {1 : n_fill}
  hz[] += dz_max;
EndFor
For i In {#wall[] - 1 : 0 : -1}
  hz[] += wall[i];
EndFor
m = #hz[]; total = sw + sm + n_fill * dz_max;
hs[] = {}; ones[] = {}; zz = 0;
For i In {0 : m - 1}
  zz += hz[i] / total; hs[] += zz; ones[] += 1;
EndFor
hs[m - 1] = 1;
Extrude {0, 0, H / 2} { Surface{surfaces[]}; Layers{ones[], hs[]}; }
Extrude {0, 0, -H / 2} { Surface{surfaces[]}; Layers{ones[], hs[]}; }
e = 1e-4;
inflow[] = Surface In BoundingBox{-e, -e, -e, e, H + e, H + e};
outflow[] = Surface In BoundingBox{L - e, -e, -e, L + e, H + e, H + e};
obstacle[] = Surface In BoundingBox{xc - r - e, yc - r - e, -e, xc + r + e, yc + r + e, H + e};
walls[] = Surface In BoundingBox{-e, -e, -e, L + e, e, H + e};
walls[] += Surface In BoundingBox{-e, H - e, -e, L + e, H + e, H + e};
walls[] += Surface In BoundingBox{-e, -e, -e, L + e, H + e, e};
walls[] += Surface In BoundingBox{-e, -e, H - e, L + e, H + e, H + e};
Physical Volume("fluid") = {Volume{:}};
Physical Surface("inflow") = {inflow[]};
Physical Surface("outflow") = {outflow[]};
Physical Surface("duct_walls") = {walls[]};
Physical Surface("obstacle") = {obstacle[]};
