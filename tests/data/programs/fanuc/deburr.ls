/PROG  DEBURR	Macro
/ATTR
OWNER  = MNEDITOR;
COMMENT = "deburr, offline";
PROG_SIZE = 0;
LINE_COUNT = 49;
PROTECT = READ_WRITE;
TCD:  STACK_SIZE = 0,
      TASK_PRIORITY = 50,
      TIME_SLICE = 0,
      BUSY_LAMP_OFF = 0,
      ABORT_REQUEST = 0,
      PAUSE_REQUEST = 0;
DEFAULT_GROUP = 1,1,*,*,*;
CONTROL_CODE = 00000000 00000000;
/MN
   1:  UFRAME_NUM=7 ;
   2:  UTOOL_NUM=4 ;
   3:J PR[1:park] 30% FINE ;
   4:J PR[R[5]] 30% FINE ;
   5: J P[1] 100% CNT100 ; ! approach 0
   6:J P[2] 60% FINE    ;
   7:J P[3] 60% FINE    ;
   8:J P[4] 60% FINE    ;
   9: J P[5] 100% CNT100 ; ! approach 4
  10:J P[6] 60% FINE    ;
  11:J P[7] 60% FINE    ;
  12:J P[8] 60% FINE    ;
  13: J P[9] 100% CNT100 ; ! approach 8
  14:J P[10] 60% FINE    ;
  15:J P[11] 60% FINE    ;
  16:J P[12] 60% FINE    ;
  17: J P[13] 100% CNT100 ; ! approach 12
  18:J P[14] 60% FINE    ;
  19:J P[15] 60% FINE    ;
  20:J P[16] 60% FINE    ;
  21: J P[17] 100% CNT100 ; ! approach 16
  22:J P[18] 60% FINE    ;
  23:J P[19] 60% FINE    ;
  24:J P[20] 60% FINE    ;
  25: J P[21] 100% CNT100 ; ! approach 20
  26:J P[22] 60% FINE    ;
  27:  !deburr the outer edge: arcs and lines ;
  28:L P[23] 250mm/sec CNT25    ;
  29:L P[24] 250mm/sec CNT25    ;
  30:L P[25] 250mm/sec CNT25    ;
  31:C P[26] 
       P[27] 150mm/sec CNT100 ;
  32:L P[28] 250mm/sec CNT75    ;
  33:A P[29] 120mm/sec CNT100    ;
  34:A P[30] 120mm/sec CNT100    ;
  35:A P[31] 120mm/sec CNT100    ;
  36:L P[32] 250mm/sec CNT75    ;
  37:L P[33] 250mm/sec CNT75    ;
  38:C P[34] 
       P[35] 150mm/sec CNT100 ;
  39:L P[36] 250mm/sec CNT25    ;
  40:L P[37] 40mm/sec FINE Tool_Offset,PR[9]    ;
  41:L P[38] 250mm/sec CNT25    ;
  42:L P[39] 250mm/sec CNT25    ;
  43:L P[40] 250mm/sec CNT75    ;
  44:L P[41] 250mm/sec CNT25    ;
  45:L P[42] 250mm/sec CNT75    ;
  46:  !back off by an increment ;
  47:L P[43] 100mm/sec FINE INC    ;
  48:J PR[2:"pounce"] 100% FINE    ;
  49:J PR[1:park] 30% FINE ;
/POS
PR[1:"park"]{
  GP1:
    UF : 0, UT : 4,
    J1=  -30.000 deg,  J2= 0.000 deg,	J3=0.000 deg,
    J4= 0.00 deg, J5=   -90.000 deg,  J6= 0.0000 deg
};
P[1]{
  GP1:
    UF : 7, UT : 4,
    J1=  -15.063 deg,  J2= -19.037 deg,	J3=-24.525 deg,
    J4= -88.50 deg, J5=   -102.114 deg,  J6= -85.3334 deg
};
P[2]{
  GP1:
    UF : 7, UT : 4,
    J1=  33.999 deg,  J2= 27.105 deg,	J3=-43.828 deg,
    J4= -122.18 deg, J5=   -20.085 deg,  J6= -144.3169 deg
};
P[3]{
  GP1:
    UF : 7, UT : 4,
    J1=  63.450 deg,  J2= 19.950 deg,	J3=-29.064 deg,
    J4= 145.53 deg, J5=   -63.815 deg,  J6= -159.5483 deg
};
P[4]{
  GP1:
    UF : 7, UT : 4,
    J1=  -28.469 deg,  J2= -18.050 deg,	J3=31.200 deg,
    J4= -146.83 deg, J5=   -23.189 deg,  J6= 85.7219 deg
};
P[5]{
  GP1:
    UF : 7, UT : 4,
    J1=  38.380 deg,  J2= -7.273 deg,	J3=12.540 deg,
    J4= -1.22 deg, J5=   -42.599 deg,  J6= -75.0817 deg,
	E1=  1290.000  mm
};
P[6]{
  GP1:
    UF : 7, UT : 4,
    J1=  71.052 deg,  J2= 24.527 deg,	J3=-31.549 deg,
    J4= -135.72 deg, J5=   -75.578 deg,  J6= 71.5791 deg
};
P[7]{
  GP1:
    UF : 7, UT : 4,
    J1=  13.907 deg,  J2= 32.509 deg,	J3=11.432 deg,
    J4= 160.38 deg, J5=   -28.400 deg,  J6= -78.5223 deg
};
P[8]{
  GP1:
    UF : 7, UT : 4,
    J1=  80.131 deg,  J2= 41.693 deg,	J3=-37.523 deg,
    J4= -74.11 deg, J5=   -105.114 deg,  J6= 93.5920 deg
};
P[9]{
  GP1:
    UF : 7, UT : 4,
    J1=  44.798 deg,  J2= -5.243 deg,	J3=-13.954 deg,
    J4= -164.37 deg, J5=   -52.495 deg,  J6= -119.8843 deg
   GP2:
	UF : 7, UT : 4,
	J1=    45.000 deg,	J2=   -10.000 deg
};
P[10]{
  GP1:
    UF : 7, UT : 4,
    J1=  62.843 deg,  J2= -10.710 deg,	J3=21.303 deg,
    J4= 73.60 deg, J5=   -44.603 deg,  J6= -127.2388 deg
};
P[11]{
  GP1:
    UF : 7, UT : 4,
    J1=  -17.185 deg,  J2= -5.175 deg,	J3=-17.027 deg,
    J4= -98.79 deg, J5=   -40.844 deg,  J6= -11.5705 deg
};
P[12]{
  GP1:
    UF : 7, UT : 4,
    J1=  -56.831 deg,  J2= -1.017 deg,	J3=-22.937 deg,
    J4= 30.85 deg, J5=   -53.755 deg,  J6= -109.9360 deg
};
P[13]{
  GP1:
    UF : 7, UT : 4,
    J1=  43.908 deg,  J2= 11.744 deg,	J3=-18.968 deg,
    J4= -122.39 deg, J5=   -52.782 deg,  J6= -28.9731 deg
};
P[14]{
  GP1:
    UF : 7, UT : 4,
    J1=  77.591 deg,  J2= -13.862 deg,	J3=30.256 deg,
    J4= 25.47 deg, J5=   -90.913 deg,  J6= -2.9175 deg
};
P[15]{
  GP1:
    UF : 7, UT : 4,
    J1=  74.035 deg,  J2= 23.252 deg,	J3=-8.002 deg,
    J4= 75.52 deg, J5=   -86.030 deg,  J6= -78.6369 deg
};
P[16]{
  GP1:
    UF : 7, UT : 4,
    J1=  -28.994 deg,  J2= 36.343 deg,	J3=32.336 deg,
    J4= 101.62 deg, J5=   -46.108 deg,  J6= 27.9943 deg
};
P[17]{
  GP1:
    UF : 7, UT : 4,
    J1=  -72.222 deg,  J2= 46.707 deg,	J3=-4.536 deg,
    J4= -152.00 deg, J5=   -20.170 deg,  J6= 120.2392 deg
};
P[18]{
  GP1:
    UF : 7, UT : 4,
    J1=  76.996 deg,  J2= 44.732 deg,	J3=-29.775 deg,
    J4= -103.23 deg, J5=   -97.994 deg,  J6= -70.0229 deg
};
P[19]{
  GP1:
    UF : 7, UT : 4,
    J1=  61.031 deg,  J2= -33.073 deg,	J3=-37.004 deg,
    J4= 86.12 deg, J5=   -91.929 deg,  J6= -65.4001 deg
};
P[20]{
  GP1:
    UF : 7, UT : 4,
    J1=  -60.787 deg,  J2= -38.166 deg,	J3=7.711 deg,
    J4= 105.28 deg, J5=   -104.399 deg,  J6= -33.1927 deg
};
P[21]{
  GP1:
    UF : 7, UT : 4,
    J1=  82.477 deg,  J2= 32.801 deg,	J3=-49.247 deg,
    J4= -90.48 deg, J5=   -66.850 deg,  J6= -53.1142 deg
};
P[22]{
  GP1:
    UF : 7, UT : 4,
    J1=  46.281 deg,  J2= 49.265 deg,	J3=-13.531 deg,
    J4= -113.44 deg, J5=   -54.731 deg,  J6= -122.9734 deg
};
P[23]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =-33.10 mm,  Y =  -709.8356  mm, Z =	1110.8  mm,
    W = 102.947 deg,P = -35.669 deg,    R = -54.40242 deg
};
P[24]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =50.38 mm,  Y =  1188.9479  mm, Z =	514.4  mm,
    W = -50.082 deg,P = 34.216 deg,    R = -50.48939 deg
};
P[25]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'F U T, 0, 0, 0',
    X =-28.91 mm,  Y =  1347.1694  mm, Z =	866.5  mm,
    W = 13.558 deg,P = -43.230 deg,    R = -120.62804 deg
};
P[26]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =423.49 mm,  Y =  -122.0792  mm, Z =	1230.7  mm,
    W = -11.493 deg,P = 28.002 deg,    R = -107.51254 deg
};
P[27]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =-173.46 mm,  Y =  -1016.3369  mm, Z =	1179.8  mm,
    W = 138.463 deg,P = -61.310 deg,    R = -46.73486 deg
};
P[28]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =-194.96 mm,  Y =  -140.0005  mm, Z =	1509.2  mm,
    W = -161.938 deg,P = -83.433 deg,    R = -73.78237 deg
};
P[29]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'F U T, 0, 0, 0',
    X =-268.25 mm,  Y =  -1220.5555  mm, Z =	863.4  mm,
    W = 80.346 deg,P = 27.281 deg,    R = 3.48967 deg
};
P[30]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =444.24 mm,  Y =  -851.3578  mm, Z =	63.1  mm,
    W = 86.302 deg,P = -14.277 deg,    R = 102.59551 deg
};
P[31]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =-529.04 mm,  Y =  292.4284  mm, Z =	1818.9  mm,
    W = 20.391 deg,P = 43.298 deg,    R = 105.22641 deg
};
P[32]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 1',
    X =-181.84 mm,  Y =  -627.2924  mm, Z =	1430.2  mm,
    W = -1.571 deg,P = 72.327 deg,    R = -31.71259 deg
};
P[33]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'F U T, 0, 0, 0',
    X =447.39 mm,  Y =  -810.6225  mm, Z =	434.9  mm,
    W = 106.558 deg,P = 6.118 deg,    R = 69.45761 deg
};
P[34]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =-110.82 mm,  Y =  1156.3990  mm, Z =	357.1  mm,
    W = 160.105 deg,P = 57.374 deg,    R = -161.10445 deg
};
P[35]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =305.50 mm,  Y =  840.2888  mm, Z =	1245.2  mm,
    W = -9.460 deg,P = -15.869 deg,    R = -158.11115 deg
};
P[36]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =204.97 mm,  Y =  -953.3964  mm, Z =	387.1  mm,
    W = 149.178 deg,P = 27.338 deg,    R = -10.76700 deg
};
P[37]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'F U T, 0, 0, 0',
    X =458.21 mm,  Y =  250.9191  mm, Z =	1018.3  mm,
    W = 26.143 deg,P = -35.701 deg,    R = -104.14621 deg
};
P[38]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =690.23 mm,  Y =  -75.1728  mm, Z =	749.3  mm,
    W = -120.021 deg,P = 44.280 deg,    R = 154.45747 deg
};
P[39]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =597.41 mm,  Y =  69.2693  mm, Z =	1096.0  mm,
    W = -89.188 deg,P = 6.115 deg,    R = -61.76436 deg
};
P[40]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =-76.83 mm,  Y =  442.6413  mm, Z =	1288.3  mm,
    W = 42.528 deg,P = -34.693 deg,    R = 119.46113 deg
};
P[41]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'F U T, 0, 0, 0',
    X =-9.00 mm,  Y =  -1162.2777  mm, Z =	1186.5  mm,
    W = -8.189 deg,P = 67.651 deg,    R = -73.65451 deg
};
P[42]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =613.46 mm,  Y =  387.6764  mm, Z =	1355.6  mm,
    W = 62.098 deg,P = 55.146 deg,    R = 61.98228 deg
};
P[43]{
  GP1:
    UF : 7, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =0.00 mm,  Y =  0.0000  mm, Z =	50.0  mm,
    W = 0.000 deg,P = 0.000 deg,    R = 0.00000 deg
};
PR[2:"pounce"]{
  GP1:
    UF : 0, UT : 4,   CONFIG : 'N U T, 0, 0, 0',
    X =931.85 mm,  Y =  666.2002  mm, Z =	1474.8  mm,
    W = 9.646 deg,P = -23.716 deg,    R = -107.59202 deg
};
/END
