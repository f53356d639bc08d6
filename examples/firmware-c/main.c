/* kinecal's C ABI on a Cortex-M4F (QEMU mps2-an386): the Rust firmware example's checks
   (examples/firmware), in C through include/kinecal.h, against the same host-computed values
   (reference.h, generated with reference.rs from one source by examples/firmware/src/generate.rs).

   Stages: 1 stream the CSV through kc_csv (16 bytes per read); 2 float forward kinematics (also
   of the coupled arm) and the 24-column Jacobian; 3 the LM stepper in idle slices of 5 poses
   while the servo tick holds a pose, a snapshot halfway that a fresh solver resumes from
   bit-identical, the identified model replaces MODEL; 4 a 50 ms trajectory of 6-D pose targets,
   one tracker call per 1 ms tick; 5 BENCH lines and the stack high-water mark.
   PSO and the BPNN are not in the C ABI, so their stages of the Rust firmware are not here. */
#include "kinecal.h"
#include "reference.h"
#include "rt.h"

#define N KC_JOINTS
#define P 24
#define ID_POSES REF_ID_POSES
#define VAL_POSES REF_VAL_POSES
#define TICKS REF_TICKS
/* Instructions per 1 kHz servo period (a ~100 MHz M4F at ~1 instruction per cycle). */
#define PERIOD_INSNS 100000u
/* Longest the idle loop may stay away from its other duties: 2 periods. */
#define SLICE_LIMIT_INSNS (2u * PERIOD_INSNS)
/* Poses per LM slice. */
#define LM_SLICE 5u
/* Room for one stepper snapshot (the "flash page"). */
#define SNAPSHOT_BYTES 8192u

_Static_assert(REF_JOINTS == KC_JOINTS, "the scenario has the ABI's joint count");
_Static_assert(REF_PARAMS == P && P <= KC_LM_MAX_PARAMS, "24 parameters fit the solver");

/* The measurement file as the host generated it (examples/firmware/data/measurements.csv),
   assembled in by csv.S. */
extern const uint8_t measurements_csv_start[], measurements_csv_end[];
/* A diagnosed UR10 model as a binary model (ur10_diagnosed.kcm, see README.md), assembled in
   by model.S. */
extern const uint8_t diagnosed_kcm_start[], diagnosed_kcm_end[];

/* Handles live in static memory the firmware owns. */
static kc_robot nominal, coupled, truth;
/* The model the servo tick compensates with (replaced when an identification finishes). */
static kc_robot model;
/* The diagnosed UR10 (joint tables) and its geometry alone. */
static kc_robot diagnosed, diagnosed_geometry;
static kc_lm lm, lm_resumed;
static kc_csv csv;
static kc_fk fk;
static kc_tracker servo_tracker, trajectory_tracker;
static kc_param params[P];
/* The same 24 codes converted once, for the Jacobian in loops. */
static kc_param_set param_set;
static kc_measurement id[ID_POSES], val[VAL_POSES];
static size_t n_id, n_val;
static uint8_t flash[SNAPSHOT_BYTES];

static uint32_t passed, failed;

/* ---- checks ---- */

/* Prints `CHECK ok|FAIL name: ` ; the caller writes the detail and ends the line. */
static void check(const char *name, bool ok) {
    if (ok) {
        passed++;
        p_str("CHECK ok   ");
    } else {
        failed++;
        p_str("CHECK FAIL ");
    }
    p_str(name);
    p_str(": ");
}

/* |got - want| <= tol. */
static void close_to(const char *name, double got, double want, double tol) {
    double d = got - want;
    check(name, (d < 0 ? -d : d) <= tol);
    unsigned dec = 0;
    for (double x = tol; x < 0.999 && dec < 9; x *= 10.0) dec++;
    p_fx(got, 6);
    p_str(" vs host f64 ");
    p_fx(want, 6);
    p_str(" (tolerance ");
    p_fx(tol, dec);
    p_str(")");
    p_nl();
}

static void must(kc_status s, const char *what) {
    if (s != KC_OK) {
        p_str("FATAL ");
        p_str(what);
        p_str(": ");
        p_str(kc_status_message(s));
        p_nl();
        semihost_exit(1);
    }
}

static float sqrt_f32(float x) {
    float r;
    __asm__("vsqrt.f32 %0, %1" : "=t"(r) : "t"(x));
    return r;
}

static float dist3(const float a[3], const float b[3]) {
    float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return sqrt_f32(dx * dx + dy * dy + dz * dz);
}

static float absf(float x) { return x < 0 ? -x : x; }
static float maxf(float a, float b) { return a > b ? a : b; }

static uint32_t f32_bits(float x) {
    union {
        float f;
        uint32_t u;
    } c = {x};
    return c.u;
}

/* ---- robots ---- */

static void build_robot(kc_robot *r, const float rows[N][4]) {
    kc_joint_row j[N];
    for (int i = 0; i < N; i++) {
        j[i] = (kc_joint_row){rows[i][0], rows[i][1], rows[i][2], rows[i][3], 0.0f, REF_LIMITS[i][0],
                              REF_LIMITS[i][1]};
    }
    must(kc_robot_init(r, N, j, 0, REF_TOOL_MM), "robot");
}

/* Rows, base and tool of two robots equal bit for bit. */
static bool same_robot(const kc_robot *a, const kc_robot *b) {
    kc_joint_row ra[N], rb[N];
    kc_frame fa, fb;
    float ta[3], tb[3];
    if (kc_robot_rows(a, ra, &fa, ta) != KC_OK || kc_robot_rows(b, rb, &fb, tb) != KC_OK) return false;
    const float *pa = &ra[0].alpha_rad, *pb = &rb[0].alpha_rad;
    for (size_t k = 0; k < (sizeof ra) / (sizeof(float)); k++)
        if (f32_bits(pa[k]) != f32_bits(pb[k])) return false;
    for (int k = 0; k < 3; k++) {
        if (f32_bits(fa.xyz_mm[k]) != f32_bits(fb.xyz_mm[k]) ||
            f32_bits(fa.rpy_rad[k]) != f32_bits(fb.rpy_rad[k]) || f32_bits(ta[k]) != f32_bits(tb[k]))
            return false;
    }
    return true;
}

/* ---- 1. stream ---- */

/* A UART receive FIFO: at most 16 bytes per read. */
struct uart {
    const uint8_t *rx, *end;
};

static size_t uart_read(void *ctx, uint8_t *buf, size_t len) {
    struct uart *u = ctx;
    size_t n = (size_t)(u->end - u->rx);
    if (n > 16) n = 16;
    if (n > len) n = len;
    for (size_t i = 0; i < n; i++) buf[i] = u->rx[i];
    u->rx += n;
    return n;
}

struct stream_result {
    double sums[2];
    uint32_t errors;
};

static void stream_all(void *ctx) {
    struct stream_result *r = ctx;
    static struct uart u;
    u.rx = measurements_csv_start;
    u.end = measurements_csv_end;
    if (kc_csv_init(&csv, uart_read, &u) != KC_OK) fatal("CSV header refused");
    size_t set, temp, extras;
    if (kc_csv_extra_index(&csv, "set", &set) != KC_OK || kc_csv_extra_index(&csv, "temp_c", &temp) != KC_OK)
        fatal("CSV lacks the set/temp_c columns");
    must(kc_csv_extra_count(&csv, &extras), "CSV extras");
    for (;;) {
        kc_csv_record rec;
        double extra[KC_CSV_MAX_EXTRAS];
        kc_status s = kc_csv_next_raw(&csv, &rec, extra, extras);
        if (s == KC_END) break;
        if (s != KC_OK) {
            kc_csv_error e;
            kc_csv_last_error(&csv, &e);
            p_str("CSV line ");
            p_u32(e.line);
            p_str(" column ");
            p_u32(e.column);
            p_str(": ");
            p_str(kc_csv_error_message(e.kind));
            p_nl();
            r->errors++;
            if (s != KC_CSV_ERROR) break;
            continue;
        }
        /* As the Rust firmware sums: joints then coordinates, each from -0.0. */
        double q = -0.0, x = -0.0;
        for (int j = 0; j < N; j++) q += rec.q_deg[j];
        for (int j = 0; j < 3; j++) x += rec.xyz_mm[j];
        r->sums[0] += q + x;
        r->sums[1] += extra[temp];
        kc_measurement m;
        if (kc_measurement_from_deg(rec.q_deg, rec.xyz_mm, &m) != KC_OK) {
            r->errors++;
        } else if (extra[set] == 0.0) {
            if (n_id < ID_POSES) id[n_id++] = m; else r->errors++;
        } else {
            if (n_val < VAL_POSES) val[n_val++] = m; else r->errors++;
        }
    }
}

static void stream(void) {
    struct stream_result r = {{0.0, 0.0}, 0};
    uint32_t insns = insns_of(stream_all, &r);
    p_str("stream: ");
    p_u32((uint32_t)n_id);
    p_str(" + ");
    p_u32((uint32_t)n_val);
    p_str(" records over the UART in ");
    p_u32(insns);
    p_str(" instructions");
    p_nl();
    check("csv.records", n_id == ID_POSES && n_val == VAL_POSES && r.errors == 0);
    p_u32((uint32_t)n_id);
    p_str(" identification + ");
    p_u32((uint32_t)n_val);
    p_str(" held-out poses, ");
    p_u32(r.errors);
    p_str(" errors");
    p_nl();
    if (n_id != ID_POSES || n_val != VAL_POSES) fatal("records missing: cannot go on");
    close_to("csv.sum", r.sums[0], REF_CSV_SUMS[0], 1e-6);
    close_to("csv.temp_sum", r.sums[1], REF_CSV_SUMS[1], 1e-9);
}

/* ---- 2. kinematics ---- */

static float fk_worst(const kc_robot *r, const float want[][3], int n) {
    float worst = 0.0f, p[3];
    for (int i = 0; i < n; i++) {
        must(kc_fk_point(&fk, r, id[i].q, p), "fk");
        worst = maxf(worst, dist3(p, want[i]));
    }
    return worst;
}

static void kinematics(void) {
    float worst = fk_worst(&nominal, REF_NOMINAL_FK, 4);
    check("fk.f32", worst < 2e-3f);
    p_str("max |p_f32 - p_f64| = ");
    p_fx(worst * 1e3f, 3);
    p_str(" µm");
    p_nl();
    /* The FANUC way of reading J3 (from the horizontal, q3 = J3 + J2). */
    worst = fk_worst(&coupled, REF_COUPLED_FK, 4);
    check("fk.coupled_f32", worst < 2e-3f);
    p_str("max |p_f32 - p_f64| = ");
    p_fx(worst * 1e3f, 3);
    p_str(" µm");
    p_nl();

    float p[3], cols[P][3];
    must(kc_fk_point(&fk, &nominal, id[0].q, p), "fk");
    bool ok = kc_fk_jacobian_set(&fk, &nominal, &param_set, &cols[0][0], 3 * P) == KC_OK;
    worst = 0.0f;
    for (int k = 0; k < P; k++) {
        static const float zero[3] = {0, 0, 0};
        float norm = dist3(REF_JACOBIAN[k], zero);
        worst = maxf(worst, dist3(cols[k], REF_JACOBIAN[k]) / maxf(norm, 1.0f));
    }
    check("jacobian.f32", ok && worst < 1e-5f);
    p_str("max relative column error ");
    p_fx(worst * 1e6f, 3);
    p_str(" ppm");
    p_nl();
    float rms = -1.0f;
    must(kc_rms_error(&nominal, id, ID_POSES, &rms), "rms");
    close_to("fk.nominal_rms_mm", rms, REF_NOMINAL_RMS_MM, 1e-4);
}

/* ---- the servo tick and the idle scheduler ---- */

/* The servo tick while background work runs: holds a pose, compensated every period with
   whatever model MODEL holds at that moment. */
static struct servo {
    kc_target target;
    float nominal_q[N];
    uint32_t worst, faults;
} servo;

static void servo_init(void) {
    for (int j = 0; j < N; j++) servo.nominal_q[j] = REF_NOMINAL_JOINTS[0][j];
    servo.target.kind = KC_TARGET_POSE;
    must(kc_fk_pose(&fk, &nominal, servo.nominal_q, servo.target.xyz_mm, servo.target.rot), "fk pose");
    must(kc_tracker_init(&servo_tracker, 0), "tracker");
}

static void servo_tick(void *ctx) {
    (void)ctx;
    kc_solution s;
    if (kc_tracker_next(&servo_tracker, &model, &servo.target, servo.nominal_q, &s) != KC_OK) servo.faults++;
}

enum work { WORK_STEP, WORK_SNAPSHOT, WORK_DONE };

struct idle {
    uint32_t periods, slices, total, worst_slice, snapshot;
};

struct slice_call {
    enum work (*f)(void *);
    void *ctx;
    enum work result;
};

static void slice_run(void *ctx) {
    struct slice_call *c = ctx;
    c->result = c->f(c->ctx);
}

/* Background work in 1 kHz periods: each period runs the servo tick, then slices until the
   period's remaining instructions are used up or a slice reports that the work is done. */
static struct idle idle_run(uint32_t limit_periods, enum work (*f)(void *), void *ctx) {
    struct idle s = {0, 0, 0, 0, 0};
    struct slice_call c = {f, ctx, WORK_STEP};
    for (;;) {
        s.periods++;
        uint32_t tick = insns_of(servo_tick, 0);
        if (tick > servo.worst) servo.worst = tick;
        uint32_t left = tick < PERIOD_INSNS ? PERIOD_INSNS - tick : 0;
        for (;;) {
            uint32_t n = insns_of(slice_run, &c);
            s.slices++;
            s.total += n;
            if (c.result == WORK_SNAPSHOT) s.snapshot = n;
            else if (n > s.worst_slice) s.worst_slice = n;
            if (c.result == WORK_DONE) return s;
            if (n >= left) break;
            left -= n;
        }
        if (s.periods >= limit_periods) fatal("background work did not finish in time");
    }
}

static void idle_report(const struct idle *s, const char *what) {
    p_str(what);
    p_str(": ");
    p_u32(s->slices);
    p_str(" slices in ");
    p_u32(s->periods);
    p_str(" servo periods, ");
    p_u32(s->total);
    p_str(" instructions in all, worst slice ");
    p_u32(s->worst_slice);
    p_str(", snapshot slice ");
    p_u32(s->snapshot);
    p_nl();
    check("idle.slice_bounded", s->worst_slice <= SLICE_LIMIT_INSNS);
    p_str(what);
    p_str(": worst slice ");
    p_u32(s->worst_slice);
    p_str(" ≤ ");
    p_u32(SLICE_LIMIT_INSNS);
    p_str(" instructions");
    p_nl();
}

/* ---- 3. identify ---- */

static float lm_pose_insns;

struct lm_slice {
    kc_lm *lm;
    bool saved;
    size_t len;
    uint32_t at;
    kc_status error;
};

static void lm_step1(void *ctx) {
    kc_lm_progress p;
    (void)kc_lm_step(ctx, id, ID_POSES, 1, &p);
}

static enum work lm_slice(void *ctx) {
    struct lm_slice *s = ctx;
    kc_lm_progress p;
    kc_lm_get_progress(s->lm, &p);
    if (!s->saved && p.iteration * 2 >= REF_LM_ITERATIONS) {
        /* Halfway: this slice writes the state to flash instead of stepping. */
        s->saved = kc_lm_save(s->lm, flash, sizeof flash, &s->len) == KC_OK;
        s->at = p.iteration;
        return WORK_SNAPSHOT;
    }
    kc_status st = kc_lm_step(s->lm, id, ID_POSES, LM_SLICE, &p);
    if (st != KC_OK) {
        s->error = st;
        return WORK_DONE;
    }
    return p.stopped ? WORK_DONE : WORK_STEP;
}

static bool same_progress(const kc_lm_progress *a, const kc_lm_progress *b) {
    return a->iteration == b->iteration && a->evaluations == b->evaluations &&
           f32_bits(a->cost) == f32_bits(b->cost) && a->stopped == b->stopped && a->converged == b->converged;
}

static const char *stop_name(uint8_t s) {
    static const char *const names[] = {"running", "Converged", "SmallStep", "MaxIterations", "NoProgress"};
    return s < 5 ? names[s] : "?";
}

static void identify(void) {
    kc_lm_config cfg;
    must(kc_lm_config_default(&cfg), "lm config");
    must(kc_lm_init(&lm, &nominal, params, P, &cfg), "lm init");
    /* One pose into the normal equations (poses 2..=49 of the first pass; the first call also
       validates the data, the 50th also analyses identifiability). The run continues. */
    lm_step1(&lm);
    lm_pose_insns = per_call_once(ID_POSES - 2, lm_step1, &lm);

    struct lm_slice s = {&lm, false, 0, 0, KC_OK};
    struct idle idle = idle_run(10000, lm_slice, &s);
    if (s.error != KC_OK) {
        p_str("FATAL LM refused the data: ");
        p_str(kc_status_message(s.error));
        p_nl();
        semihost_exit(1);
    }
    kc_lm_progress first;
    must(kc_lm_get_progress(&lm, &first), "lm progress");
    p_str("identify: LM ");
    p_str(stop_name(first.stopped));
    p_str(" after ");
    p_u32(first.iteration);
    p_str(" iterations (host f64: ");
    p_u32(REF_LM_ITERATIONS);
    p_str("), cost ");
    p_fx(first.cost, 6);
    p_str(" mm²");
    p_nl();
    idle_report(&idle, "identify");

    static kc_robot identified;
    must(kc_lm_robot(&lm, &identified), "lm robot");
    float rms = -1.0f;
    must(kc_rms_error(&identified, id, ID_POSES, &rms), "rms");
    close_to("lm.id_rms_mm", rms, REF_LM_ID_RMS_MM, 1e-3);
    must(kc_rms_error(&identified, val, VAL_POSES, &rms), "rms");
    close_to("lm.val_rms_mm", rms, REF_LM_VAL_RMS_MM, 1e-3);
    float worst = 0.0f, p[3];
    for (int i = 0; i < VAL_POSES; i++) {
        must(kc_fk_point(&fk, &identified, val[i].q, p), "fk");
        worst = maxf(worst, dist3(p, REF_LM_VAL_PREDICTED[i]));
    }
    check("lm.model_vs_host", worst < 5e-3f);
    p_str("f32 and f64 identified models differ by ");
    p_fx(worst * 1e3f, 3);
    p_str(" µm at most on held-out poses");
    p_nl();

    /* Power lost at the snapshot: a fresh solver restored from flash runs to the end again. */
    if (!s.saved) fatal("LM finished before its snapshot");
    must(kc_lm_init(&lm_resumed, &nominal, params, P, &cfg), "lm init");
    kc_status restored = kc_lm_restore(&lm_resumed, flash, s.len);
    kc_lm_progress end = {0, 0, 0.0f, 0, 0};
    bool ended = false;
    for (uint32_t steps = 0; restored == KC_OK && steps < 100000; steps++) {
        if (kc_lm_step(&lm_resumed, id, ID_POSES, LM_SLICE, &end) != KC_OK) break;
        if (end.stopped) {
            ended = true;
            break;
        }
    }
    static kc_robot resumed;
    bool same = ended && same_progress(&end, &first) && kc_lm_robot(&lm_resumed, &resumed) == KC_OK &&
                same_robot(&resumed, &identified);
    check("lm.snapshot_resume", restored == KC_OK && same);
    p_u32((uint32_t)s.len);
    p_str("-byte snapshot at iteration ");
    p_u32(s.at);
    p_str(", restored into a fresh solver: ");
    p_str(kc_status_message(restored));
    p_str(", same end: ");
    p_str(same ? "true" : "false");
    p_nl();

    check("servo.hold", servo.faults == 0 && servo.worst <= PERIOD_INSNS);
    p_str("held pose through all background work, worst tick ");
    p_u32(servo.worst);
    p_str(" instructions, ");
    p_u32(servo.faults);
    p_str(" faults");
    p_nl();
    /* The identified model replaces MODEL (no interrupt runs the servo tick here). */
    must(kc_robot_copy(&model, &identified), "model");
}

/* ---- 4. servo trajectory ---- */

struct track_call {
    const kc_target *target;
    const float *qn;
    kc_solution *out;
    kc_status status;
};

static void track(void *ctx) {
    struct track_call *c = ctx;
    c->status = kc_tracker_next(&trajectory_tracker, &model, c->target, c->qn, c->out);
}

static void trajectory(void) {
    must(kc_tracker_init(&trajectory_tracker, 0), "tracker");
    uint32_t worst_tick = 0, faults = 0;
    float err2 = 0.0f, worst_err = 0.0f, worst_raw = 0.0f, worst_dq = 0.0f;
    for (int k = 0; k < TICKS; k++) {
        /* The interpolator's output for this tick: nominal joints and the pose they give. */
        const float *qn = REF_NOMINAL_JOINTS[k];
        kc_target target = {.kind = KC_TARGET_POSE};
        must(kc_fk_pose(&fk, &nominal, qn, target.xyz_mm, target.rot), "fk pose");
        kc_solution s;
        struct track_call c = {&target, qn, &s, KC_OK};
        uint32_t insns = insns_of(track, &c);
        if (insns > worst_tick) worst_tick = insns;
        if (c.status != KC_OK) {
            faults++;
            continue;
        }
        /* Where the real robot goes with and without compensation. */
        float p[3];
        must(kc_fk_point(&fk, &truth, s.q, p), "fk");
        float e = dist3(p, target.xyz_mm);
        must(kc_fk_point(&fk, &truth, qn, p), "fk");
        float raw = dist3(p, target.xyz_mm);
        err2 += e * e;
        worst_err = maxf(worst_err, e);
        worst_raw = maxf(worst_raw, raw);
        for (int j = 0; j < N; j++) worst_dq = maxf(worst_dq, absf(s.q[j] - REF_COMMANDS[k][j]));
    }
    float rms = sqrt_f32(err2 / (float)TICKS);
    p_str("servo: ");
    p_u32(TICKS);
    p_str(" ticks, true robot off target by ");
    p_fx(rms, 4);
    p_str(" mm RMS, ");
    p_fx(worst_err, 4);
    p_str(" mm max (uncompensated ");
    p_fx(worst_raw, 3);
    p_str(" mm max)");
    p_nl();
    check("servo.deadline", faults == 0 && worst_tick <= PERIOD_INSNS);
    p_u32(TICKS - faults);
    p_str(" of ");
    p_u32(TICKS);
    p_str(" ticks compensated, worst tick ");
    p_u32(worst_tick);
    p_str(" of ");
    p_u32(PERIOD_INSNS);
    p_str(" instructions");
    p_nl();
    check("servo.accuracy", faults == 0 && rms <= 0.03f && worst_err <= 0.1f && worst_raw > 10.0f * worst_err);
    p_str("RMS ");
    p_fx(rms, 4);
    p_str(" mm ≤ 0.03, max ");
    p_fx(worst_err, 4);
    p_str(" mm ≤ 0.1, uncompensated ");
    p_fx(worst_raw, 3);
    p_str(" mm");
    p_nl();
    check("servo.vs_host", worst_dq < 2e-5f);
    p_str("joint commands within ");
    p_fx(worst_dq * 1e6f, 3);
    p_str(" µrad of the host's f64 ones");
    p_nl();
}

/* ---- 5. a diagnosed model from a binary model ---- */

/* Readings of the first 8 measured poses of data/ur10/ur10_random_poses.csv (from the second
   row; degrees): inside the travel the diagnosed joint tables cover. */
#define UR10_POSES 8
static const float UR10_Q_DEG[UR10_POSES][6] = {
    {-234.021174f, -154.389207f, 97.330060f, -116.367728f, 56.880385f, -3.856206f},
    {-209.382843f, -161.827346f, 116.101303f, -127.770734f, 8.507392f, -6.000358f},
    {-255.990667f, -169.946158f, 117.843095f, -115.508291f, 83.303480f, -1.254096f},
    {-255.867481f, -136.025337f, 72.284928f, -127.435554f, 45.783969f, 2.937446f},
    {-241.806524f, -160.495219f, 98.579680f, -115.878995f, 32.496103f, -1.462526f},
    {-224.859579f, -132.758905f, 70.590692f, -135.375603f, 27.181232f, 12.229097f},
    {-246.608483f, -156.891887f, 72.883669f, -98.370551f, 84.218493f, 0.607507f},
    {-222.871988f, -177.685671f, 88.217739f, -111.981163f, 13.730876f, 17.511767f},
};
static kc_target diag_target;
static float diag_seed[KC_MAX_JOINTS];
static kc_solution diag_sol;

static void bench_compensate_tables(void *ctx) {
    (void)ctx;
    (void)kc_compensate(&diagnosed, &diag_target, diag_seed, 0, &diag_sol);
}

/* Loads the diagnosed model, compensates point targets with its tables (from seeds 0.2° off,
   as a nominal inverse kinematics would give), and measures one compensation. */
static void diagnosed_model(void) {
    size_t len = (size_t)(diagnosed_kcm_end - diagnosed_kcm_start);
    uint32_t joints = 0;
    must(kc_robot_load(&diagnosed, diagnosed_kcm_start, len), "load .kcm");
    must(kc_robot_joints(&diagnosed, &joints), "joints");
    /* A truncated copy is refused and the handle keeps the model. */
    kc_status truncated = kc_robot_load(&diagnosed, diagnosed_kcm_start, len - 1);
    check("model.load", joints == N && truncated == KC_MODEL_INVALID);
    p_u32((uint32_t)len);
    p_str(" bytes, ");
    p_u32(joints);
    p_str(" joints; a truncated copy refused");
    p_nl();

    /* The same geometry without the joint corrections. */
    kc_joint_row rows[KC_MAX_JOINTS];
    kc_frame base;
    float tool[3];
    must(kc_robot_rows(&diagnosed, rows, &base, tool), "rows");
    must(kc_robot_init(&diagnosed_geometry, N, rows, &base, tool), "geometry");

    float worst = 0.0f, tables2 = 0.0f, worst_seed = 0.0f;
    uint32_t ok = 0;
    for (int k = 0; k < UR10_POSES; k++) {
        float q[KC_MAX_JOINTS] = {0}, p[3], g[3];
        for (int j = 0; j < N; j++) q[j] = UR10_Q_DEG[k][j] * 0.017453292519943295f;
        kc_target t = {.kind = KC_TARGET_POINT};
        must(kc_fk_point(&fk, &diagnosed, q, t.xyz_mm), "fk");
        must(kc_fk_point(&fk, &diagnosed_geometry, q, g), "fk");
        float d = dist3(g, t.xyz_mm);
        tables2 += d * d;
        float seed[KC_MAX_JOINTS] = {0};
        for (int j = 0; j < N; j++) seed[j] = q[j] + (j % 2 ? 0.2f : -0.2f) * 0.017453292519943295f;
        must(kc_fk_point(&fk, &diagnosed, seed, p), "fk");
        worst_seed = maxf(worst_seed, dist3(p, t.xyz_mm));
        kc_solution s;
        if (kc_compensate(&diagnosed, &t, seed, 0, &s) == KC_OK) ok++;
        must(kc_fk_point(&fk, &diagnosed, s.q, p), "fk");
        worst = maxf(worst, dist3(p, t.xyz_mm));
        if (k == 0) {
            diag_target = t;
            for (int j = 0; j < N; j++) diag_seed[j] = seed[j];
        }
    }
    float tables = sqrt_f32(tables2 / (float)UR10_POSES);
    check("model.tables", tables > 0.05f);
    p_str("the joint tables move the tool by ");
    p_fx(tables, 4);
    p_str(" mm RMS at the measured poses");
    p_nl();
    check("model.compensate", ok == UR10_POSES && worst <= 0.01f && worst_seed > 100.0f * worst);
    p_u32(ok);
    p_str(" of ");
    p_u32(UR10_POSES);
    p_str(" targets met, worst ");
    p_fx(worst, 5);
    p_str(" mm on the model with its tables (seeds off by up to ");
    p_fx(worst_seed, 3);
    p_str(" mm)");
    p_nl();
}

/* ---- 6. benches ---- */

static void report(const char *name, float insns) {
    p_str("BENCH ");
    p_str(name);
    p_str(" ");
    p_u32((uint32_t)(insns + 0.5f));
    p_nl();
}

static float bench_q[N], bench_p[3], bench_cols[P][3];
static kc_target bench_target;
static kc_solution bench_sol;

static void bench_fk(void *ctx) {
    (void)ctx;
    (void)kc_fk_point(&fk, &nominal, bench_q, bench_p);
}

static void bench_jacobian(void *ctx) {
    (void)ctx;
    (void)kc_fk_jacobian_set(&fk, &nominal, &param_set, &bench_cols[0][0], 3 * P);
}

static void bench_compensate(void *ctx) {
    (void)ctx;
    (void)kc_compensate(&model, &bench_target, REF_NOMINAL_JOINTS[0], 0, &bench_sol);
}

static void benches(void) {
    for (int j = 0; j < N; j++) bench_q[j] = id[0].q[j];
    report("fk_f32", per_call(bench_fk, 0));
    must(kc_fk_point(&fk, &nominal, bench_q, bench_p), "fk");
    report("jacobian_f32", per_call(bench_jacobian, 0));

    /* One 6-D target from the nominal seed (a cold start), with the identified model. */
    bench_target.kind = KC_TARGET_POSE;
    must(kc_fk_pose(&fk, &nominal, REF_NOMINAL_JOINTS[0], bench_target.xyz_mm, bench_target.rot), "fk pose");
    /* NULL settings: the library defaults, as the Rust firmware's Config::default(). */
    if (kc_compensate(&model, &bench_target, REF_NOMINAL_JOINTS[0], 0, &bench_sol) == KC_OK) {
        p_str("compensate: cold start from the nominal seed, ");
        p_u32(bench_sol.iterations);
        p_str(" Newton steps");
        p_nl();
    }
    report("compensate_f32", per_call(bench_compensate, 0));
    report("lm_pose_f32", lm_pose_insns);
    /* One point target from a seed 0.2° off, on the diagnosed model with its joint tables. */
    report("compensate_tables_f32", per_call(bench_compensate_tables, 0));
}

int main(void) {
    counter_init();
    p_str("kinecal C firmware: Cortex-M4F (QEMU mps2-an386), C ABI (include/kinecal.h), float, ");
    p_u32(N);
    p_str(" joints, ");
    p_u32(P);
    p_str(" parameters");
    p_nl();

    build_robot(&nominal, REF_NOMINAL_ROWS);
    build_robot(&truth, REF_TRUE_ROWS);
    must(kc_robot_copy(&coupled, &nominal), "robot copy");
    must(kc_robot_set_coupling(&coupled, 2, 1, 1.0f), "coupling");
    must(kc_params_mdh(params), "params");
    must(kc_param_set_init(&param_set, params, P), "param set");
    must(kc_fk_init(&fk), "fk init");
    /* At boot the controller runs on the nominal model. */
    must(kc_robot_copy(&model, &nominal), "model");
    servo_init();

    stream();
    kinematics();
    identify();
    trajectory();
    diagnosed_model();
    benches();

    p_str("STACK ");
    p_u32(stack_high_water());
    p_nl();
    p_u32(passed);
    p_str(" passed, ");
    p_u32(failed);
    p_str(" failed");
    p_nl();
    semihost_exit(failed == 0 ? 0 : 1);
}
