/PROG  WELD_CELL
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "robocal sample";
PROG_SIZE	= 6210;
CREATE		= DATE 24-03-11  TIME 08:15:02;
MODIFIED	= DATE 24-03-12  TIME 14:40:51;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 55;
MEMORY_SIZE	= 6654;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/APPL
/MN
   1:  !Weld cell, fixture A and B ;
   2:  !robocal sample, written by hand ;
   3:  UFRAME_NUM=0 ;
   4:  UTOOL_NUM=1 ;
   5:J P[1:home] 100% FINE    ;
   6:J P[2] 80% CNT50    ;
   7:J P[3] 100% CNT50    ;
   8:J P[4] 80% CNT100    ;
   9:J P[5] 50% CNT100    ;
  10:J P[6] 20% CNT50    ;
  11:J P[7] 80% CNT100    ;
  12:J P[8] 50% CNT0    ;
  13:J P[9] 50% CNT0    ;
  14:J P[10] 50% CNT100    ;
  15:J P[11] 50% CNT50    ;
  16:J P[12] 50% CNT0    ;
  17:J P[13] 100% CNT100    ;
  18:J P[14] 50% CNT100    ;
  19:J P[15] 100% CNT0    ;
  20:J P[16] 20% CNT50    ;
  21:J P[17] 20% CNT50    ;
  22:J P[18] 20% CNT50    ;
  23:J P[19] 50% CNT50    ;
  24:J P[20] 20% CNT0    ;
  25:  UFRAME_NUM=3 ;
  26:  UTOOL_NUM=2 ;
  27:  !Seam 1 in UF 3 ;
  28:L P[21] 100mm/sec CNT100    ;
  29:L P[22] 250mm/sec CNT50    ;
  30:L P[23] 100mm/sec CNT10    ;
  31:L P[24] 500mm/sec CNT10    ;
  32:L P[25] 500mm/sec CNT50    ;
  33:L P[26] 250mm/sec CNT100    ;
  34:C P[27]    
    :  P[28] 300mm/sec CNT50    ;
  35:L P[29] 500mm/sec CNT100    ;
  36:L P[30] 800mm/sec FINE
    :  Arc Start[2]    ;
  37:L P[31] 500mm/sec CNT50    ;
  38:L P[32] 500mm/sec CNT100    ;
  39:L P[33] 500mm/sec CNT100    ;
  40:L P[34] 250mm/sec CNT50    ;
  41:L P[35] 100mm/sec CNT50    ;
  42:C P[36]    
    :  P[37] 200mm/sec CNT50    ;
  43:L P[38] 250mm/sec CNT50    ;
  44:L P[39] 500mm/sec CNT10    ;
  45:L P[40] 250mm/sec CNT100    ;
  46:L P[41:seam end] 50mm/sec FINE Offset,PR[4:shift]    ;
  47:L P[42] 100mm/sec CNT10    ;
  48:L P[43] 250mm/sec CNT50    ;
  49:L P[44] 500mm/sec CNT100    ;
  50:  Arc End[2] ;
  51:  //L P[3] 100mm/sec FINE    ;
  52:J PR[1:safe] 50% FINE    ;
  53:J P[1:home] 100% FINE    ;
  54:  !P[2] again, and a point left for later ;
  55:J P[2] 100% FINE    ;
/POS
P[1:"home"]{
   GP1:
	UF : 0, UT : 1,
	J1=     0.000 deg,	J2=   -20.000 deg,	J3=    10.000 deg,
	J4=     0.000 deg,	J5=   -80.000 deg,	J6=     0.000 deg
};
P[2]{
   GP1:
	UF : 0, UT : 2,
	J1=    32.761 deg,	J2=   -30.840 deg,	J3=     5.603 deg,
	J4=   116.253 deg,	J5=   -26.545 deg,	J6=     5.106 deg
};
P[3]{
   GP1:
	UF : 0, UT : 1,
	J1=     5.043 deg,	J2=   -29.214 deg,	J3=    11.465 deg,
	J4=    34.227 deg,	J5=   -81.808 deg,	J6=   -41.285 deg
};
P[4]{
   GP1:
	UF : 0, UT : 1,
	J1=   -64.008 deg,	J2=    40.018 deg,	J3=    31.262 deg,
	J4=  -153.166 deg,	J5=   -68.689 deg,	J6=    14.847 deg
};
P[5]{
   GP1:
	UF : 0, UT : 2,
	J1=    36.892 deg,	J2=    42.689 deg,	J3=     0.636 deg,
	J4=    47.325 deg,	J5=   -52.692 deg,	J6=  -158.421 deg
};
P[6]{
   GP1:
	UF : 0, UT : 1,
	J1=   -14.947 deg,	J2=   -39.122 deg,	J3=     9.020 deg,
	J4=   139.476 deg,	J5=  -103.139 deg,	J6=    27.223 deg
};
P[7]{
   GP1:
	UF : 0, UT : 1,
	J1=   -26.663 deg,	J2=   -24.071 deg,	J3=    27.452 deg,
	J4=    77.529 deg,	J5=   -20.346 deg,	J6=   -95.892 deg
};
P[8]{
   GP1:
	UF : 0, UT : 2,
	J1=   -49.095 deg,	J2=    24.943 deg,	J3=   -22.846 deg,
	J4=  -155.696 deg,	J5=   -82.739 deg,	J6=  -100.777 deg
};
P[9]{
   GP1:
	UF : 0, UT : 1,
	J1=   -42.050 deg,	J2=    23.468 deg,	J3=   -10.512 deg,
	J4=  -134.310 deg,	J5=   -45.127 deg,	J6=   -79.304 deg
};
P[10]{
   GP1:
	UF : 0, UT : 1,
	J1=   -10.200 deg,	J2=   -26.981 deg,	J3=   -18.440 deg,
	J4=  -136.723 deg,	J5=   -95.068 deg,	J6=    26.427 deg
};
P[11]{
   GP1:
	UF : 0, UT : 2,
	J1=   -38.063 deg,	J2=   -37.398 deg,	J3=   -33.817 deg,
	J4=   128.561 deg,	J5=   -96.375 deg,	J6=  -131.935 deg
};
P[12]{
   GP1:
	UF : 0, UT : 1,
	J1=    14.349 deg,	J2=    14.061 deg,	J3=    11.674 deg,
	J4=   -48.502 deg,	J5=  -103.195 deg,	J6=   114.407 deg
};
P[13]{
   GP1:
	UF : 0, UT : 1,
	J1=   -17.760 deg,	J2=    -8.363 deg,	J3=   -32.501 deg,
	J4=   158.713 deg,	J5=  -105.344 deg,	J6=   109.293 deg
};
P[14]{
   GP1:
	UF : 0, UT : 2,
	J1=    36.224 deg,	J2=    -5.306 deg,	J3=    -0.502 deg,
	J4=   143.351 deg,	J5=  -105.911 deg,	J6=   118.983 deg
};
P[15]{
   GP1:
	UF : 0, UT : 1,
	J1=    84.013 deg,	J2=   -10.043 deg,	J3=   -49.589 deg,
	J4=   -79.054 deg,	J5=   -58.484 deg,	J6=  -160.551 deg
};
P[16]{
   GP1:
	UF : 0, UT : 1,
	J1=   -30.106 deg,	J2=    35.567 deg,	J3=     5.653 deg,
	J4=   158.218 deg,	J5=   -23.031 deg,	J6=   122.450 deg
};
P[17]{
   GP1:
	UF : 0, UT : 2,
	J1=    -2.395 deg,	J2=   -33.157 deg,	J3=    -9.762 deg,
	J4=    40.659 deg,	J5=   -13.058 deg,	J6=    52.339 deg
};
P[18]{
   GP1:
	UF : 0, UT : 1,
	J1=    27.084 deg,	J2=   -36.300 deg,	J3=   -37.086 deg,
	J4=  -155.311 deg,	J5=   -36.723 deg,	J6=   150.054 deg
};
P[19]{
   GP1:
	UF : 0, UT : 1,
	J1=    43.032 deg,	J2=   -22.559 deg,	J3=    13.848 deg,
	J4=    59.976 deg,	J5=   -15.522 deg,	J6=  -113.750 deg
};
P[20]{
   GP1:
	UF : 0, UT : 2,
	J1=    60.607 deg,	J2=   -23.041 deg,	J3=    23.929 deg,
	J4=   103.085 deg,	J5=   -82.560 deg,	J6=   -95.514 deg
};
P[21]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'F U T, 0, 0, 0',
	X =   250.611  mm,	Y =   447.784  mm,	Z =  1610.747  mm,
	W =   -34.852 deg,	P =   -72.857 deg,	R =   168.179 deg
};
P[22]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   679.401  mm,	Y =  -662.886  mm,	Z =   745.462  mm,
	W =   -58.263 deg,	P =    42.748 deg,	R =   -85.386 deg
};
P[23]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =  1771.774  mm,	Y =   408.483  mm,	Z =   777.995  mm,
	W =   -81.080 deg,	P =   -60.422 deg,	R =   -96.707 deg
};
P[24]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =  -587.470  mm,	Y =   507.173  mm,	Z =  1326.197  mm,
	W =   151.383 deg,	P =   -56.607 deg,	R =   155.344 deg
};
P[25]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =     1.597  mm,	Y =   165.121  mm,	Z =  1359.621  mm,
	W =   120.779 deg,	P =   -14.491 deg,	R =    22.466 deg
};
P[26]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 1',
	X =   908.034  mm,	Y =   728.028  mm,	Z =  1526.920  mm,
	W =   -49.753 deg,	P =    48.570 deg,	R =   -34.695 deg
};
P[27]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =  1122.456  mm,	Y =   581.371  mm,	Z =  1674.790  mm,
	W =    10.825 deg,	P =   -34.113 deg,	R =  -117.287 deg
};
P[28]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   391.812  mm,	Y =  -610.880  mm,	Z =   706.066  mm,
	W =    89.969 deg,	P =   -67.082 deg,	R =    16.516 deg
};
P[29]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   628.367  mm,	Y =  -520.828  mm,	Z =   819.907  mm,
	W =    85.023 deg,	P =     5.758 deg,	R =     0.384 deg
};
P[30]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =  -780.197  mm,	Y =   496.327  mm,	Z =  1607.925  mm,
	W =   -75.152 deg,	P =    13.755 deg,	R =   139.574 deg
};
P[31]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N D T, 0, 0, 0',
	X =  -147.633  mm,	Y =  -111.501  mm,	Z =  1727.569  mm,
	W =   -71.141 deg,	P =    17.229 deg,	R =  -135.514 deg
};
P[32]{
   GP1:
	UF : 3, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =  1541.009  mm,	Y =   241.818  mm,	Z =   467.965  mm,
	W =   178.355 deg,	P =   -14.587 deg,	R =    26.488 deg
};
P[33]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   121.113  mm,	Y =  -818.492  mm,	Z =  1991.257  mm,
	W =     5.676 deg,	P =    47.318 deg,	R =    50.184 deg
};
P[34]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'F U T, 0, 0, -1',
	X =  -450.540  mm,	Y =   668.826  mm,	Z =   660.054  mm,
	W =  -126.948 deg,	P =   -21.492 deg,	R =    77.688 deg
};
P[35]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =  -651.795  mm,	Y =   729.904  mm,	Z =  1113.941  mm,
	W =   -56.335 deg,	P =   -42.892 deg,	R =    -1.451 deg
};
P[36]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   672.557  mm,	Y =  -174.870  mm,	Z =   239.814  mm,
	W =  -122.332 deg,	P =    39.392 deg,	R =  -104.239 deg
};
P[37]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   793.873  mm,	Y = -1401.760  mm,	Z =  1669.603  mm,
	W =    72.174 deg,	P =   -12.094 deg,	R =    10.549 deg
};
P[38]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N D B, 0, 0, 0',
	X = -1274.400  mm,	Y =  -376.262  mm,	Z =  1539.549  mm,
	W =   105.855 deg,	P =   -65.416 deg,	R =   131.712 deg
};
P[39]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =  1082.048  mm,	Y =  -736.303  mm,	Z =   797.276  mm,
	W =  -164.459 deg,	P =   -75.651 deg,	R =   -18.083 deg
};
P[40]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =     4.381  mm,	Y =  -350.761  mm,	Z =  1441.931  mm,
	W =  -107.412 deg,	P =   -51.350 deg,	R =    63.710 deg
};
P[41:"seam end"]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   597.981  mm,	Y =  -307.002  mm,	Z =  1080.425  mm,
	W =    64.673 deg,	P =    29.469 deg,	R =   142.691 deg
};
P[42]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   788.898  mm,	Y =   231.587  mm,	Z =   817.982  mm,
	W =  -133.457 deg,	P =    27.841 deg,	R =   -86.197 deg
};
P[43]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, -1, 0, 0',
	X =  -1043.817  mm,	Y =    -15.100  mm,	Z =  -138.721  mm,
	W =  -222.318 deg,	P =   -10.923 deg,	R =    -1.981 deg
};
P[44]{
   GP1:
	UF : 5, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   590.069  mm,	Y =   163.158  mm,	Z =  1713.383  mm,
	W =   -42.764 deg,	P =   -70.226 deg,	R =   -94.191 deg
};
P[45:"spare"]{
   GP1:
	UF : 0, UT : 1,
	J1=    12.500 deg,	J2=     5.000 deg,	J3=    -3.250 deg,
	J4=     0.000 deg,	J5=   -60.000 deg,	J6=    90.000 deg
};
/END
