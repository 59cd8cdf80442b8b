/* SPDX-License-Identifier: MIT */
/**
 * @file run.h  The run driver: integrate to t_end or for N steps, with samples at every vertex,
 * every midpoint or chosen output times, dense output of the method's order, events located on
 * it, and checkpoint and progress callbacks.
 *
 * One call, dth_run(), drives a started integrator (the DTH step or a fixed-step baseline of
 * methods.h) and hands every sample to the caller's callback: the driver prints nothing, writes
 * no file and keeps no global state, so separate integrators may run in separate threads.
 * Everything the loop carries from one step to the next is in dth_run_state, a plain struct: a
 * caller that saves it next to a checkpoint of the integrator (checkpoint.h) resumes the run by
 * passing it back, bit for bit but for one step: the samples and events on the segment the
 * previous call's end cut (t_end, a terminal event) come from that segment rebuilt from its
 * midpoint (z_(k-1) = 2 zbar - z_k), and match an uninterrupted run's to round-off.
 *
 * Dense output (dth_dense_eval): on the step from the vertex z_a to z_b the driver interpolates
 * with the cubic Hermite polynomial of the two vertices and the flow u = J grad H at both, and,
 * for an ordinary DTH step, adds the quartic term that makes it pass through the step's midpoint
 * zbar (at theta = 1/2) as well. Both are exact on the vertices; the quartic one also on the
 * midpoint, so an output time that falls on the initial condition of a midpoint start returns
 * it bit for bit. The interpolation error is O(h^4) per step, below the method's O(h^2)
 * error: output at chosen times converges at order 2 like the vertices (tests/test_run.c).
 *
 * Exact end: with t_end the loop steps until the first vertex at or beyond t_end (the DTH step
 * length is not chosen but solved for), and the final sample (DTH_SAMPLE_END) is the dense
 * output at t = t_end exactly. The integrator is left at that last vertex, so extending a run
 * (resume with a later t_end) continues the very same vertices as a run made to the later t_end
 * at once. (A last step of prescribed length through a kicked segment would also end on t_end,
 * but it is not the DTH map, exists for autonomous models only, and would make the trajectory
 * depend on t_end.)
 *
 * Events: a function g(z) of the extended state is evaluated at every vertex; where it changes
 * sign over a step (in the chosen direction) the crossing is located on the dense output to
 * round-off in t by bracketing (Illinois steps with bisection), and handed to on_event. A sign
 * change that turns back within one step is not seen. A terminal event ends the run there: the
 * END sample is then the dense output at the event time.
 */
#ifndef DTH_RUN_H
#define DTH_RUN_H

#include <stddef.h>
#include "dth/model.h"
#include "dth/integrator.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Which points of the trajectory the driver samples. */
typedef enum dth_points {
    DTH_POINTS_VERTICES = 0,  /**< every `every`-th vertex z_k (and the end) */
    DTH_POINTS_MIDPOINTS = 1, /**< every `every`-th step's midpoint zbar, where H(zbar) = 0: the
                                   energy -wp is exact (a regularizer's kicked segment has its
                                   midpoint on H = 0 too); with a midpoint start the first one is the
                                   initial condition. DTH only. No END sample (it is no midpoint). */
    DTH_POINTS_TIMES = 2      /**< dense output at the output times (and at t_end) */
} dth_points;

/** What a sample is. */
typedef enum dth_sample_kind {
    DTH_SAMPLE_VERTEX = 0,   /**< the vertex z_k */
    DTH_SAMPLE_MIDPOINT = 1, /**< the midpoint of the step k -> k+1 */
    DTH_SAMPLE_TIME = 2,     /**< dense output at an output time */
    DTH_SAMPLE_END = 3,      /**< dense output at t_end or at a terminal event: the run ends here */
    DTH_SAMPLE_EVENT = 4     /**< dense output where an event function crossed zero (on_event) */
} dth_sample_kind;

/** One sample, valid during the callback only. */
typedef struct dth_sample {
    dth_sample_kind kind;
    long index;        /**< running number: of trajectory samples (sample), of events (on_event) */
    long k;            /**< VERTEX: the vertex index k; else the step k -> k+1 that holds the point */
    const double *z;   /**< the extended state (q, t, p, wp), 2n+2 values */
    /** VERTEX: the step that arrived at z_k (zeroed at the first vertex); else the step k -> k+1.
     *  For a fixed-step baseline lambda is its h and branch DTH_BRANCH_NONE. */
    const dth_step_info *step;
    double lambda_out; /**< VERTEX: the step that leaves z_k, 0 if none was taken (the last vertex) */
    const double *za, *zb; /**< the step's vertices (NULL for VERTEX samples) */
    int event;         /**< EVENT (and an END at a terminal event): index into dth_run_config.events; else -1 */
    int direction;     /**< EVENT: +1 g increased through 0, -1 it decreased */
    double err_q, err_p; /**< the estimated global error at z (dth_integrator_error_at): |dq|, |dp|; NaN
                              without an estimate (dth_options.estimate) */
} dth_sample;

/** A sample callback: 0 to go on; anything else stops the run and dth_run returns it. */
typedef int (*dth_sample_fn)(void *user, const dth_sample *s);

/** An event function: *g = g(z) for the extended state z (2n+2). 0, or a status (stops the run). */
typedef int (*dth_event_fn)(void *user, size_t n, const double *z, double *g);

/** One event. */
typedef struct dth_event {
    dth_event_fn g;  /**< the function whose zeros are located */
    void *user;      /**< passed to g */
    int direction;   /**< +1: only where g increases through 0, -1: only decreasing, 0: both */
    int terminal;    /**< 1: the run ends at the first such event */
} dth_event;

/** Parameters of the built-in event functions. */
typedef struct dth_event_spec {
    size_t index;        /**< dth_event_coordinate: which entry of z (q_i: i-1, t: n, p_i: n+i, 1-based i) */
    double value;        /**< coordinate: g = z[index] - value; time: g = t - value; distance: g = |q| - value */
    const size_t *dofs;  /**< dth_event_distance: the q indices (0-based) |q| is taken over; NULL: all */
    size_t ndofs;
} dth_event_spec;

/** g = z[index] - value (a coordinate crossing: a Poincare section). user: a dth_event_spec. */
DTH_API int dth_event_coordinate(void *user, size_t n, const double *z, double *g);
/** g = t - value (an event at a time). user: a dth_event_spec. */
DTH_API int dth_event_time(void *user, size_t n, const double *z, double *g);
/** g = sqrt(sum over dofs of q_i^2) - value (escape: increasing; collision: decreasing). */
DTH_API int dth_event_distance(void *user, size_t n, const double *z, double *g);

/** Why dth_run returned (dth_run_state.stop). */
typedef enum dth_run_stop {
    DTH_RUN_RUNNING = 0,  /**< not returned yet */
    DTH_RUN_END = 1,      /**< reached t_end or the step count */
    DTH_RUN_EVENT = 2,    /**< a terminal event */
    DTH_RUN_CALLBACK = 3, /**< a callback returned nonzero (dth_run returns its value) */
    DTH_RUN_FAILED = 4,   /**< a step failed (dth_run returns its status; the state is at the last vertex), or
                               the driver stopped after a step: DTH_EACCURACY (stop_error), DTH_ESTEPSIZE
                               (step_max); the state is then at the vertex that step arrived at */
    DTH_RUN_SAMPLES = 5   /**< the output times asked for more than DTH_RUN_MAX_SAMPLES_PER_STEP samples
                               within one step (dth_run returns DTH_EINVAL; the samples so far are valid and
                               the state is at the vertex after that step) */
} dth_run_stop;

/**
 * At most this many samples within one step. Output times far denser than the steps fill a disk
 * without resolving the trajectory (the method's steps do): dth_run_check refuses a dt that asks for
 * more from the step known before the run, and dth_run stops (DTH_RUN_SAMPLES) at a step that turns
 * out to hold more (a vertex start's first step, a longer step later, a list of times).
 */
#define DTH_RUN_MAX_SAMPLES_PER_STEP 1000000

/**
 * The loop's state: plain data, all of it, so a caller may store it (for example as a checkpoint
 * blob) and pass it back to continue. Zero it (or dth_run_state_init) for a fresh run.
 */
typedef struct dth_run_state {
    int started;         /**< 0: fresh (the driver fills the rest at its first call) */
    int pending;         /**< 1: the current vertex's VERTEX sample is still to come (it is handed
                              out once the step leaving it is known) */
    long k;              /**< index of the current vertex (steps from the run's start) */
    long k0;             /**< vertex index `every` counts from (the first vertex of this leg) */
    long samples;        /**< trajectory samples handed out */
    long events;         /**< events handed out */
    long j;              /**< index of the next output time */
    double t;            /**< time of the current vertex */
    double t_first;      /**< the run's start time (cfg->t0 of the first call) */
    dth_step_info in;    /**< the step that arrived at the current vertex */
    long crossings;      /**< steps flagged DTH_STEP_CROSSING (psi changed sign) */
    long regularized;    /**< steps flagged DTH_STEP_REGULARIZED */
    double max_ratio;    /**< largest ratio of consecutive steps around a crossing */
    int prev_crossing;   /**< the step that arrived was a crossing */
    int stop;            /**< dth_run_stop: why the last call returned */
    double t_stop;       /**< samples and events are handed out for times after this one: where the
                              last call ended (t_end, a terminal event) or the start */
    double err_q, err_p; /**< the estimated global error at the current vertex (NaN without one) */
    double q_max, p_max; /**< the largest |q|, |p| at the vertices so far (the stop rule's scale) */
    double lam_max;      /**< the largest |lambda| of the steps so far */
    double t_lam_max;    /**< the time of the vertex that step arrived at */
    long nonreversible;  /**< steps with no reverse (a flag of DTH_STEP_NONREVERSIBLE: RESET, CLOCK or
                              ONEWAY): a round trip of the run does not come back to its start */
    double e_err;        /**< a fixed-step baseline's energy error |H_phys(z_k) - H_phys(z_0)| at the current
                              vertex (0 for the DTH step, whose midpoints keep the energy) */
    double e_scale;      /**< the size of the energy's terms at the first vertex, |H_phys| + sum |y_j dH/dy_j|
                              (the scale e_err is judged by) */
} dth_run_state;

/** Zero a state (a fresh run). */
DTH_API void dth_run_state_init(dth_run_state *st);

/** What to do. Initialize with dth_run_config_default(). */
typedef struct dth_run_config {
    size_t size;            /**< sizeof(dth_run_config) where the caller was compiled (dth_run_config_default
                                 sets it; dth_run refuses another: a caller built against an older layout) */
    int has_t_end;          /**< 1: run to t_end; 0: until the vertex index reaches `steps` */
    double t_end;           /**< end time (exactly: the END sample is the dense output there) */
    long steps;             /**< vertex index to stop at (counted from the run's start) */
    double t0;              /**< start of the run's time window: output times are t0 + j dt, and no
                                 output time or event before t0 is reported (a midpoint start's
                                 first vertex lies half a step before it). NAN: the integrator's
                                 current time. */
    dth_points points;      /**< what `sample` receives */
    long every;             /**< VERTICES / MIDPOINTS: every every-th one (>= 1; counted from k0) */
    double dt;              /**< TIMES without a list: output times t0 + j dt (dt > 0; j = 0, 1, ...) */
    const double *times;    /**< TIMES: an explicit list instead, ordered in the direction of travel */
    size_t ntimes;
    dth_sample_fn sample;   /**< trajectory samples (NULL: none) */
    void *user;             /**< passed to every callback */
    const dth_event *events;/**< event functions (borrowed) */
    size_t nevents;
    dth_sample_fn on_event; /**< located events (NULL: they are still located, and terminal ones stop) */
    /** Called every `checkpoint_every` steps and once when the loop ends (before the final
     *  samples), with the integrator at the current vertex and its sample pending: the moment to
     *  save the integrator (checkpoint.h) and the state. 0 to go on, else stops the run. */
    int (*checkpoint)(void *user, const dth_run_state *st);
    long checkpoint_every;  /**< steps between checkpoints (<= 0: only the final one) */
    /** Called every `progress_every` steps (for progress lines and stop requests): 0 to go on. */
    int (*progress)(void *user, const dth_run_state *st);
    long progress_every;    /**< steps between progress calls (<= 0: never) */
    const dth_allocator *alloc; /**< the driver's workspace (one block per call); NULL: malloc */
    /** With an error estimate (dth_options.estimate): stop with DTH_EACCURACY where the steps ran away
     *  from h (a step larger than step_ratio h) and the estimated error in q or in p exceeds this
     *  fraction of the largest |q| resp. |p| seen so far (default 0.25; 0: never). A run whose steps
     *  are far too large for its orbit (a Kepler orbit of e = 0.9 started at its pericentre with
     *  h = 0.01: steps up to 96 h, the end a third of the orbit off) ends with a status instead of an
     *  orbit-sized error; a long run whose phase error grows at steps near h is left to run (its
     *  estimate says how far off it is). The DTH method of order 4 also counts as run away where its
     *  band steps (prescribed-step compositions around psi = 0, not solved for) were more than half
     *  of at least 10 steps. */
    double stop_error;
    /** The multiple of the integrator's h beyond which steps count as run away (default 16; 0: never stop;
     *  the DTH method of order 4: its 3/2 power, dth_run_step_limit). */
    double step_ratio;
    /** 1: each step record gets the local error estimate lerr (dth_step_info); 3 flows per step. */
    int local_error;
    /** > 0: a step longer than this stops the run after it, with DTH_ESTEPSIZE (st->stop = DTH_RUN_FAILED;
     *  st->lam_max and st->t_lam_max say which step; its samples are handed out, the state is at the vertex
     *  it arrived at). The guard of a run calibrated for h_max (control.h: dth_control_report.step_max,
     *  1.05 h_max): a part of the orbit the pilots did not see. 0 (the default): no bound. */
    double step_max;
} dth_run_config;

/** Defaults: steps = 0, t0 = NAN, points = VERTICES, every = 1, stop_error = 0.25, step_ratio = 16,
 *  step_max = 0, nothing else. */
DTH_API void dth_run_config_default(dth_run_config *cfg);

/**
 * The largest |lambda| that the stop rule (dth_run_config.step_ratio) does not count as run away from
 * h: step_ratio |h|; for the DTH method of order 4 step_ratio^(3/2) |h|, since its steps follow
 * tau^2 psi = const where the DTH step's follow lambda^6 psi^2 = const, so the same change of psi along
 * an orbit moves its step by the 3/2 power of the ratio (Kepler e = 0.6 from the pericentre: 21.8 h at
 * the apocentre against order 2's 7.8 h). INFINITY for step_ratio <= 0, NaN without an integrator.
 */
DTH_API double dth_run_step_limit(const dth_integrator *it, double step_ratio);

struct dth_run_setup; /* scene.h */

/**
 * The defaults, plus what a scene's run setup (scene.h) says about the run's extent and events:
 * has_t_end, t_end, steps, t0, events and nevents (borrowed from rs). The samples (points, every,
 * dt) and the callbacks stay at their defaults: the caller sets those it wants.
 */
DTH_API void dth_run_config_from_setup(dth_run_config *cfg, const struct dth_run_setup *rs);

/**
 * Whether dth_run accepts `cfg` for the integrator `it` from the loop state `st`, with a one-line
 * message naming the setting in err (may be NULL) when not: every < 1; midpoints for a method without
 * them; output times with dt <= 0 or not finite, or a dt that asks for more than
 * DTH_RUN_MAX_SAMPLES_PER_STEP rows per step of the integrator's current step; a list of times with a
 * non-finite entry or one before its predecessor in the direction of travel (equal times are
 * allowed); events without a function; t_end not finite, or behind the run's start (fresh state) or
 * behind where the last call's samples ended (st->t_stop); steps < 0, or behind the state's vertex
 * index. dth_run calls it first, on every call.
 * @return DTH_OK, DTH_EINVAL.
 */
DTH_API int dth_run_check(const dth_integrator *it, const dth_run_config *cfg, const dth_run_state *st, char *err,
                          size_t errlen);

/**
 * Run the integrator `it` (started, or restored from a checkpoint; the DTH step or a baseline,
 * whose wp, absent from its state, is -H_phys at its start: its H(z) is the energy error) as `cfg` says, from the
 * loop state `st` (zeroed: a fresh run; else one saved by an earlier call, whose vertex the
 * integrator must be at). On return `st` says where and why it stopped.
 * @return DTH_OK (the end, or a terminal event); a failed step's status (positive: the trajectory
 *   cannot go on; the samples so far are valid); a callback's nonzero value; DTH_EINVAL (a
 *   configuration dth_run_check refuses, nothing done; or, with st->stop = DTH_RUN_SAMPLES, a step
 *   that held more than DTH_RUN_MAX_SAMPLES_PER_STEP output times); DTH_ENOMEM.
 */
DTH_API int dth_run(dth_integrator *it, const dth_run_config *cfg, dth_run_state *st);

/**
 * Dense output on one step: the point at time t (written to z, 2n+2 values, z[n] = t) of the
 * interpolant through the vertices za, zb with flows ua, ub (u = J grad H, 2n+2 values each:
 * dq/dt = dH/dp, 1, dp/dt = -dH/dq, dwp/dt = -dH/dt), and through the midpoint zm at theta = 1/2
 * if zm is not NULL (the quartic form; NULL: the cubic Hermite). t at a node returns the node.
 */
DTH_API void dth_dense_eval(size_t n, const double *za, const double *zb, const double *zm, const double *ua,
                            const double *ub, double t, double *z);

/** u = J grad H at the extended state z (2n+2 values; work: 2n+1 doubles). */
DTH_API int dth_flow(const dth_model *model, const double *z, double *u, double *work);

#ifdef __cplusplus
}
#endif
#endif
