/* Generated from tensim/model/_law_layout.py by tools/law_header.py: do not edit. */
#ifndef TENSIM_CABLE_LAYOUT_H
#define TENSIM_CABLE_LAYOUT_H

#define TENSIM_CABLE_MARKER 7317.0
#define TENSIM_REFERENCE_MARKER 7318.0
#define TENSIM_MODE_REST 0.0
#define TENSIM_MODE_IMPEDANCE 1.0
#define TENSIM_MODE_PD 2.0
#define TENSIM_ACTDIM 4
#define TENSIM_DC_ACTDIM 5
#define TENSIM_IMPLICIT_EXTRA 1
#define TENSIM_THETA_DISCRETE 0.5
#define TENSIM_THETA_IMPLICITFAST 1.0

#define TENSIM_P_MARKER 0 /* CABLE_MARKER or REFERENCE_MARKER: a tensim cable, and its law's body */
#define TENSIM_P_MODE 1 /* MODE_REST, MODE_IMPEDANCE or MODE_PD */
#define TENSIM_P_MAX_SPEED 2 /* motor speed limit [m/s] */
#define TENSIM_P_MAX_TENSION 3 /* the motor reels in no further at this static tension [N] */
#define TENSIM_P_MIN_REST 4 /* floor on the rest length [m] */
#define TENSIM_P_MIN_LENGTH 5 /* no reeling in while the cable is this short [m] */
#define TENSIM_P_OFFSET_TENSION 6 /* impedance law T0 [N] */
#define TENSIM_P_GAIN_K 7 /* impedance law K [N/m] */
#define TENSIM_P_GAIN_B 8 /* impedance law B [N s/m] */
#define TENSIM_P_TARGET_LENGTH 9 /* impedance law L* [m] */

#define TENSIM_G_GAIN 0 /* stays 0: the constant of the gain (the explicit law's whole gain) */
#define TENSIM_G_STIFFNESS 1 /* cable k [N/m]: the implicit law's gain per metre of length */
#define TENSIM_G_DAMPING 2 /* cable b [N s/m]: the implicit law's gain per m/s of lengthening */
#define TENSIM_G_PD_STIFFNESS 3 /* PD motor kp [N/m]: its tension per metre of length past the target */
#define TENSIM_G_PD_DAMPING 4 /* PD motor kd [N s/m]: its tension per m/s of lengthening */

#define TENSIM_B_LAG_TIME 0 /* kinematic motor's first-order lag [s] (0: none) */
#define TENSIM_B_SATURATE 1 /* 1.0: max_tension back-drives the kinematic motor (a force cap), 0.0: stops it */
#define TENSIM_B_RESERVED 2 /* stays 0: MuJoCo's compiler reads a positive one as a damping ratio */
#define TENSIM_B_STALL_FORCE 3 /* DC motor stall force F_s [N] */
#define TENSIM_B_NO_LOAD_SPEED 4 /* DC motor no-load line speed v0 [m/s] */
#define TENSIM_B_MASS 5 /* DC motor reflected mass M [kg] */
#define TENSIM_B_VISCOUS 6 /* DC motor viscous friction c [N s/m] */
#define TENSIM_B_COULOMB 7 /* DC motor Coulomb friction F_c [N] */
#define TENSIM_B_POSITION_TIME 8 /* DC motor position loop time constant t_p [s] */
#define TENSIM_B_BACK_DRIVABLE 9 /* 1.0 where the cable may drive the spool, 0.0 for a worm gear */

#define TENSIM_A_REST 0 /* the motor's rest length l [m] */
#define TENSIM_A_PEAK 1 /* running maximum of the load-cell tension [N] */
#define TENSIM_A_PEAK_SPEED 2 /* running maximum of the motor's line speed |dl/dt| [m/s] */
#define TENSIM_A_PEAK_POWER 3 /* running maximum of the load-cell tension times the line speed [W] */
#define TENSIM_A_SPEED 4 /* DC motors only: the spool's line speed dl/dt [m/s] */
#define TENSIM_A_PULL 5 /* implicit law only, always the last: -theta while the cable is taut after this step's motor update, else 0.0 (the gain's input) */

#define TENSIM_LAYOUT_ID 2383126592u

#endif
