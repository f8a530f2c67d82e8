/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/drive.h - the axis drive of one cylinder, in the spirit of a CiA 408
 * servo valve in axis-position mode: it receives a setpoint (length,
 * velocity and force) once per cycle, runs its position loop at every
 * substep of the plant, and reports a state and fault bits.
 *
 * States (values as the DBC's DriveState):
 *   INIT   (0) before the first setpoint: valve at null (cylinder locked by
 *              its oil, drifting only by leakage).
 *   HOLD   (1) position loop on the length latched on entering HOLD.
 *   ACTIVE (2) position loop on the setpoint, interpolated within the cycle
 *              with its velocity: target = length + velocity * age.
 *   FAULT  (3) valve at null; left only by hs_drive_clear_faults (-> INIT).
 * Requests (the DBC's Mode): HS_REQ_HOLD (0), HS_REQ_ACTIVE (1).
 *   INIT/HOLD/ACTIVE + HOLD request   -> HOLD (latches the measured length)
 *   INIT/HOLD + ACTIVE request        -> ACTIVE, unless the timeout bit is
 *                                        latched (then HOLD: clear it first)
 *   FAULT + any request               -> FAULT
 * Watchdog: in ACTIVE, each cycle that starts without a new setpoint counts;
 * after timeout_cycles such cycles in a row the drive enters HOLD and sets
 * HS_FAULT_TIMEOUT. Until then it keeps extrapolating the last setpoint.
 *
 * Control law (every substep, h seconds):
 *   e   = target - L_measured                              (m)
 *   F_m = (p_A A_A - p_B A_B)_measured                      (N)
 *   HP(x) = x - LP(x), LP(x) += h w_hp (x - LP(x))          (first-order high-pass)
 *   u   = kp e + ff_gain * hs_cyl_velocity_command(v_sp, F_sp) + kf (HP(F_sp) - HP(F_m))
 *   |u| <= 1
 * The velocity feed-forward is the flow the setpoint velocity needs at the
 * load pressure of the force setpoint. The high-passed force terms are a
 * dynamic pressure feedback: they damp the oil-column resonance and build
 * the pressure a change of the force setpoint needs, without offsetting the
 * position by a steady force (a steady model error, the leakage). The
 * low-pass of F_m runs in every state, from the force given at init, so a
 * noisy first sample does not bias it; the one of F_sp restarts at the
 * setpoint on entering ACTIVE (HP(F_sp) = 0 in HOLD).
 * Faults: |e| > following_error_max in ACTIVE -> FAULT + HS_FAULT_FOLLOWING.
 *
 * Safety functions (hs_drive_monitor, every substep after hs_drive_update),
 * what a hydraulic servo drive does below its position loop:
 *   Valve monitor: the drive runs a model of its valve's spool (the same
 *     second-order dynamics, driven by its own commands) and compares it
 *     with the spool position the valve's LVDT measures. More than
 *     spool_error_max apart for spool_error_time in a row: HS_FAULT_VALVE
 *     (a spool stuck, open or at null, or a broken valve). In the model the
 *     two agree to rounding; a real valve differs by its tolerances, which
 *     the margin (0.2 of full opening, 2 ms) covers.
 *   Sensor plausibility: a flow balance of each chamber. While the length
 *     reading stays unchanged, the drive integrates the flow its valve
 *     passes at the measured spool and pressures (the valve and leakage
 *     model of hs/cylinder.h), less the flow the measured pressure change
 *     stored in the oil: the travel of the piston the flows predict,
 *       D_A = (int (Q_A - Q_L) dt - V_A / beta (p_A - p_A0)) / A_A,
 *       D_B = -(int (Q_B + Q_L) dt - V_B / beta (p_B - p_B0)) / A_B.
 *     Both beyond sensor_check_travel, same sign: HS_FAULT_SENSOR (the
 *     sensor stuck while the piston moves). Any change of the reading
 *     restarts the balance (so a flow-gain error only scales the time to
 *     detect, never accumulates); so does a pressure near 0 or the relief
 *     limit (where the chamber equation does not hold), the FAULT state or a
 *     closed blocking valve.
 *   Blocking valves: load-holding valves between the servo valve and the
 *     cylinder (pilot-operated check valves), closed by the drive in FAULT
 *     (its safety chain) and while the master asks for them closed (the
 *     setpoints' Block: valve at null, setpoints ignored; the controller's
 *     ESTOP and holding FAULT) in block_time, open otherwise: closed, no oil
 *     flows to or from the chambers but the piston's internal leakage, so
 *     a cylinder whose servo valve is stuck open stops. `block` is their
 *     opening (1 open, 0 closed); the plant scales the valve flows by it.
 */
#ifndef HS_DRIVE_H
#define HS_DRIVE_H

#include "hs/params.h"

typedef enum { HS_DRIVE_INIT = 0, HS_DRIVE_HOLD = 1, HS_DRIVE_ACTIVE = 2, HS_DRIVE_FAULT = 3 } hs_drive_state_t;

typedef enum { HS_REQ_HOLD = 0, HS_REQ_ACTIVE = 1 } hs_drive_request_t;

/* Fault bits (the DBC's Faults signal). Latched until hs_drive_clear_faults. */
#define HS_FAULT_TIMEOUT 0x01u   /**< bit 0: no setpoint for timeout_cycles (-> HOLD) */
#define HS_FAULT_FOLLOWING 0x02u /**< bit 1: following error (-> FAULT) */
#define HS_FAULT_END_STOP 0x04u  /**< bit 2: cylinder beyond a stroke end (warning) */
#define HS_FAULT_SENSOR 0x08u    /**< bit 3: length sensor implausible (-> FAULT) */
#define HS_FAULT_VALVE 0x10u     /**< bit 4: valve fault (-> FAULT; raised from outside) */
#define HS_FAULT_PRESSURE 0x20u  /**< bit 5: a chamber pressure at 0 or at the relief limit (warning) */
#define HS_FAULT_COMM 0x40u      /**< bit 6: communication (E2E) fault (warning; raised by the bus layer) */
#define HS_FAULT_INTERNAL 0x80u  /**< bit 7: non-finite state (-> FAULT) */
/** Bits whose occurrence puts the drive in FAULT. */
#define HS_FAULTS_SEVERE (HS_FAULT_FOLLOWING | HS_FAULT_SENSOR | HS_FAULT_VALVE | HS_FAULT_INTERNAL)

typedef struct {
    hs_drive_state_t state;
    uint32_t faults;            /**< latched fault bits */
    hs_drive_request_t request; /**< last requested mode */
    double sp_length;           /**< last length setpoint, m */
    double sp_velocity;         /**< last velocity setpoint, m/s */
    double sp_force;            /**< last force setpoint, N */
    double sp_age;              /**< time since the start of the setpoint's cycle, s */
    int fresh;                  /**< a setpoint arrived since the last cycle start */
    uint32_t missed;            /**< consecutive ACTIVE cycles without a setpoint */
    double hold_length;         /**< target in HOLD, m */
    double meas_lp;             /**< low-pass of the measured force, N */
    double ref_lp;              /**< low-pass of the force setpoint, N */
    int ref_valid;              /**< ref_lp is initialised (0 after entering ACTIVE) */
    double ff_command;          /**< velocity feed-forward of the current setpoint (cached), -1..1 */
    int ff_valid;               /**< ff_command belongs to the current setpoint */
    double command;             /**< last valve command, -1..1 */
    double error;               /**< last position error, m */
    double spool_model;         /**< valve monitor: the modelled spool position, -1..1 */
    double spool_model_rate;    /**< its rate, 1/s */
    double spool_error;         /**< |modelled - measured spool| of the last substep */
    double spool_error_time;    /**< how long it has been above spool_error_max, s */
    double chk_length;          /**< sensor plausibility: the length reading the balance started at, m */
    double chk_pa, chk_pb;      /**< the measured pressures then, Pa */
    double chk_qa, chk_qb;      /**< integrated valve + leakage flows into A and B since then, m^3 */
    double chk_travel;          /**< the smaller |predicted travel| of the two chambers (0 if they disagree), m */
    int chk_valid;              /**< a balance is under way */
    double block;               /**< blocking valves' opening, 0 (closed) .. 1 (open) */
    int block_request;          /**< the last setpoint's Block (1: closed), applied at the next cycle */
    int blocked;                /**< the master asks for the blocking valves closed, valve at null */
    double spool_error_peak;    /**< the largest spool_error seen (the monitors' margin, for reports) */
    double chk_travel_peak;     /**< the largest chk_travel seen, m */
} hs_drive_t;

/** A drive in INIT with no faults, its blocking valves open; force0 (N) is
 *  the cylinder force at start, the initial value of the measured-force
 *  low-pass. */
void hs_drive_init(hs_drive_t *d, double force0);

/**
 * Stores a setpoint (length m, velocity m/s, force N, requested mode) for
 * the next cycle. HS_E_ARG for NULL, a non-finite value or an unknown mode
 * (the setpoint is then ignored: it does not feed the watchdog).
 */
hs_status_t hs_drive_setpoint(hs_drive_t *d, double length, double velocity, double force, hs_drive_request_t mode);

/**
 * The master's load-holding request with the next setpoint (the DBC's
 * Block): closed != 0 puts the valve at null and closes the blocking
 * valves from the next cycle that applies a fresh setpoint, the setpoints
 * and the requested mode then ignored (the drive holds, HOLD); 0 opens
 * them again, a drive in HOLD then holds where it is. HS_E_ARG for NULL.
 */
hs_status_t hs_drive_set_block(hs_drive_t *d, int closed);

/**
 * Start of a cycle: applies the request of a fresh setpoint (state
 * transitions), runs the watchdog. meas_length (m) is the drive's current
 * length measurement, latched as the target when entering HOLD.
 */
void hs_drive_cycle(hs_drive_t *d, const hs_drive_params_t *dp, double meas_length);

/**
 * One control substep of h seconds: returns the valve command (-1..1) from
 * the measured length (m) and chamber pressures (Pa); 0 in INIT and FAULT
 * and while blocked
 * (the measured-force low-pass still runs). Checks the following error.
 * Advances the setpoint age by h.
 */
double hs_drive_update(hs_drive_t *d, const hs_drive_params_t *dp, const hs_cyl_params_t *c, double meas_length,
                       double meas_pa, double meas_pb, double h);

/**
 * The drive's safety functions for one substep of h seconds (see above),
 * after hs_drive_update: the valve monitor (meas_spool: the spool position
 * measured at the substep's start, fraction of full opening), the sensor
 * plausibility (meas_length m, meas_pa and meas_pb Pa: the same samples
 * hs_drive_update got) and the blocking valves (`block` moves towards 0 in
 * FAULT or blocked, else towards 1, at 1 / block_time per second). A fault found here
 * puts the drive in FAULT with its command at 0 (read d->command after).
 * Non-finite inputs: no check fires on them (the plant's internal fault
 * covers a non-finite state).
 */
void hs_drive_monitor(hs_drive_t *d, const hs_drive_params_t *dp, const hs_cyl_params_t *c, double meas_length,
                      double meas_pa, double meas_pb, double meas_spool, double h);

/** Sets fault bits (e.g. HS_FAULT_COMM from the bus layer); severe bits put the drive in FAULT. */
void hs_drive_raise(hs_drive_t *d, uint32_t bits);

/** Sets fault bits and enters FAULT whatever they are (the plant's supply
 *  monitor: a pressure loss is a warning bit, but no valve may open then). */
void hs_drive_fail(hs_drive_t *d, uint32_t bits);

/** Clears all fault bits; FAULT -> INIT (valve at null until the next setpoint). */
void hs_drive_clear_faults(hs_drive_t *d);

#endif /* HS_DRIVE_H */
