/* A C client of a binary model (.kcm) through include/kinecal.h: loads it, checks the joint
 * count and the refusals (truncated, corrupted: the handle keeps the model it had), checks
 * that kc_fk_pose's tool pose is a pose target kc_compensate meets at the same readings, then
 * computes forward kinematics and compensated commands for the caller, which compares them
 * with the library's f64 (host-tests/tests/library/model_blob.rs). Strict C99. */
#include "kinecal.h"
#include <string.h>

static kc_robot robot;
static kc_robot nominal;
static kc_fk fk;
static uint8_t copy[16384];

/* Returns 0, or the negative number of the step that failed. The model must have `joints`
 * joints (6 or 7). `q` and `seeds` hold `n` poses of `joints` readings (rad), `targets` n points
 * (mm); `points` receives the model's point at each `q`, `commands` the compensated command
 * (`joints` readings) from each seed towards each target. */
int kc_model_test(const uint8_t *blob, size_t len, uint32_t joints, const float *q,
                  const float *seeds, const float *targets, size_t n, float *points,
                  float *commands) {
    uint32_t got = 0;
    size_t i, met;
    float before[3], after[3];
    if (kc_robot_load(&robot, blob, len) != KC_OK) return -1;
    if (kc_robot_joints(&robot, &got) != KC_OK || got != joints) return -2;
    if (kc_fk_init(&fk) != KC_OK) return -3;
    if (len > sizeof copy || len < 16) return -4;
    /* Refused blobs leave the loaded model as it was. */
    if (kc_fk_point(&fk, &robot, q, before) != KC_OK) return -5;
    if (kc_robot_load(&robot, blob, len - 1) != KC_MODEL_INVALID) return -6;
    memcpy(copy, blob, len);
    copy[len / 2] ^= 0x10;
    if (kc_robot_load(&robot, copy, len) != KC_MODEL_INVALID) return -7;
    copy[len / 2] ^= 0x10;
    copy[4] = 2; /* another layout version */
    if (kc_robot_load(&robot, copy, len) != KC_MODEL_INVALID) return -8;
    if (kc_robot_load(&robot, NULL, len) != KC_NULL_POINTER) return -9;
    if (kc_fk_point(&fk, &robot, q, after) != KC_OK) return -10;
    if (memcmp(before, after, sizeof before) != 0) return -11;
    for (i = 0; i < n; i++) {
        if (kc_fk_point(&fk, &robot, q + joints * i, points + 3 * i) != KC_OK) return -12;
    }
    /* kc_fk_pose gives the tool frame (the flange axes times the model's tool orientation),
       the frame kc_compensate reads a pose target as: handed back from the same readings, it
       is met there and the command is those readings. A pose whose 6-D Jacobian is too poorly
       conditioned (KC_SOLUTION_SINGULAR: a point target there is no such case) is skipped;
       at least half must be met. */
    for (i = 0, met = 0; i < n; i++) {
        kc_target t;
        kc_solution s;
        kc_status st;
        uint32_t j;
        memset(&t, 0, sizeof t);
        t.kind = KC_TARGET_POSE;
        if (kc_fk_pose(&fk, &robot, q + joints * i, t.xyz_mm, t.rot) != KC_OK) return -14;
        st = kc_compensate(&robot, &t, q + joints * i, NULL, &s);
        if (st == KC_COMPENSATE_FAILED && s.status == KC_SOLUTION_SINGULAR) continue;
        if (st != KC_OK) return -15;
        for (j = 0; j < joints; j++) {
            float d = s.q[j] - q[joints * i + j];
            if (d > 1e-4f || d < -1e-4f) return -16;
        }
        met++;
    }
    if (2 * met < n) return -17;
    for (i = 0; i < n; i++) {
        kc_target t;
        kc_solution s;
        memset(&t, 0, sizeof t);
        t.kind = KC_TARGET_POINT;
        memcpy(t.xyz_mm, targets + 3 * i, sizeof t.xyz_mm);
        if (kc_compensate(&robot, &t, seeds + joints * i, NULL, &s) != KC_OK) return -13;
        memcpy(commands + joints * i, s.q, joints * sizeof s.q[0]);
    }
    return 0;
}

/* The Cartesian route for a controller that keeps its nominal kinematics: loads the calibrated
 * model `blob` and the nominal robot `nominal_blob`, and for each of the `n` point targets
 * (`targets`, mm; seeds `seeds`, `joints` readings each) writes the point to send into `sent`
 * (3 per target). Returns 0, or the negative number of the step that failed. */
int kc_model_cartesian(const uint8_t *blob, size_t len, const uint8_t *nominal_blob,
                       size_t nominal_len, uint32_t joints, const float *seeds,
                       const float *targets, size_t n, float *sent) {
    size_t i;
    if (kc_robot_load(&robot, blob, len) != KC_OK) return -1;
    if (kc_robot_load(&nominal, nominal_blob, nominal_len) != KC_OK) return -2;
    for (i = 0; i < n; i++) {
        kc_target t, out;
        kc_solution s;
        memset(&t, 0, sizeof t);
        t.kind = KC_TARGET_POINT;
        memcpy(t.xyz_mm, targets + 3 * i, sizeof t.xyz_mm);
        if (kc_compensate_cartesian(&robot, &nominal, &t, seeds + joints * i, NULL, &s, &out) !=
            KC_OK)
            return -3;
        if (out.kind != KC_TARGET_POINT) return -4;
        memcpy(sent + 3 * i, out.xyz_mm, sizeof out.xyz_mm);
    }
    return 0;
}
