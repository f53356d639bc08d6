/* A C client of a binary model (.kcm) through include/kinecal.h: loads it, checks the joint
 * count and the refusals (truncated, corrupted: the handle keeps the model it had), then
 * computes forward kinematics and compensated commands for the caller, which compares them
 * with the library's f64 (host-tests/tests/firmware_model.rs). Strict C99. */
#include "kinecal.h"
#include <string.h>

static kc_robot robot;
static kc_fk fk;
static uint8_t copy[16384];

/* Returns 0, or the negative number of the step that failed. `q` and `seeds` hold `n` poses of
 * KC_JOINTS readings (rad), `targets` n points (mm); `points` receives the model's point at each
 * `q`, `commands` the compensated command from each seed towards each target. */
int kc_model_test(const uint8_t *blob, size_t len, const float *q, const float *seeds,
                  const float *targets, size_t n, float *points, float *commands) {
    uint32_t joints = 0;
    size_t i;
    float before[3], after[3];
    if (kc_robot_load(&robot, blob, len) != KC_OK) return -1;
    if (kc_robot_joints(&robot, &joints) != KC_OK || joints != KC_JOINTS) return -2;
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
        if (kc_fk_point(&fk, &robot, q + KC_JOINTS * i, points + 3 * i) != KC_OK) return -12;
    }
    for (i = 0; i < n; i++) {
        kc_target t;
        kc_solution s;
        memset(&t, 0, sizeof t);
        t.kind = KC_TARGET_POINT;
        memcpy(t.xyz_mm, targets + 3 * i, sizeof t.xyz_mm);
        if (kc_compensate(&robot, &t, seeds + KC_JOINTS * i, NULL, &s) != KC_OK) return -13;
        memcpy(commands + KC_JOINTS * i, s.q, sizeof s.q);
    }
    return 0;
}
