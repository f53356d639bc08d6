/* The C ABI from C: a host program over include/kinecal.h that checks real properties of
 * every part of the surface and every error path. Compiled by host-tests/build.rs (cc crate,
 * -std=c99 -Wall -Wextra -Werror -pedantic) and run by host-tests/tests/library/c_abi.rs, which passes
 * in the reference values it computed with the library in f64. Returns the number of failed
 * checks (0 = all passed). */
#include "check.h"
#include "kinecal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

int failures;
int checks;

#define N_ID 50
#define N_VAL 10

/* The nominal arm (an ER20-C10-like 6R, as the Rust firmware's scenario): alpha deg, a mm,
 * theta deg, d mm. */
static const double ROWS[KC_JOINTS][4] = {
    {0.0, 0.0, 0.0, 504.0},   {-90.0, 170.0, -90.0, 0.0}, {0.0, 780.0, 0.0, 0.0},
    {-90.0, 140.0, 0.0, 760.0}, {90.0, 0.0, 0.0, 0.0},     {-90.0, 0.0, 0.0, 125.0},
};
static const float TOOL[3] = {40.0f, 30.0f, 120.0f};
static const double Q_MID_DEG[KC_JOINTS] = {20.0, -70.0, 20.0, 30.0, 45.0, -30.0};

/* Handles: statics, as in firmware (zeroed: not initialised until their *_init). */
static kc_robot nominal, truth, model, scratch, never_robot;
static kc_fk fk;
static kc_lm lm, lm2, lm_bad;
static kc_tracker tracker;
static kc_measurement id_data[N_ID], val_data[N_VAL];
static uint8_t flash[16384], flash2[16384];

static void rows_of(const double r[KC_JOINTS][4], kc_joint_row out[KC_JOINTS]) {
  int j;
  for (j = 0; j < KC_JOINTS; j++) {
    out[j].alpha_rad = (float)(r[j][0] * DEG);
    out[j].a_mm = (float)r[j][1];
    out[j].theta_rad = (float)(r[j][2] * DEG);
    out[j].d_mm = (float)r[j][3];
    out[j].beta_rad = 0.0f;
    out[j].lower_rad = (float)(-180.0 * DEG);
    out[j].upper_rad = (float)(180.0 * DEG);
  }
}

/* Deterministic joint readings: q = mid ± 40° (a small LCG). */
static unsigned long lcg_state = 12345;
static double uniform(void) {
  lcg_state = (lcg_state * 1103515245ul + 12345ul) & 0x7ffffffful;
  return (double)lcg_state / (double)0x7fffffff * 2.0 - 1.0;
}
static void random_q(float q[KC_JOINTS]) {
  int j;
  for (j = 0; j < KC_JOINTS; j++) q[j] = (float)((Q_MID_DEG[j] + 40.0 * uniform()) * DEG);
}

static float dist3(const float a[3], const float b[3]) {
  float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return sqrtf(dx * dx + dy * dy + dz * dz);
}

static void test_status_messages(void) {
  uint32_t s;
  for (s = 0; s <= 16; s++) CHECK(kc_status_message(s) != NULL && kc_status_message(s)[0] != 0);
  CHECK(strcmp(kc_status_message(KC_OK), "ok") == 0);
  CHECK(strcmp(kc_status_message(999), "unknown status") == 0);
  CHECK(kc_csv_error_message(KC_CSV_NOT_A_NUMBER) != NULL);
  CHECK(strcmp(kc_csv_error_message(200), "unknown CSV error") == 0);
  CHECK(sizeof(kc_robot) == KC_ROBOT_SIZE && sizeof(kc_lm) == KC_LM_SIZE);
  CHECK(sizeof(kc_fk) == KC_FK_SIZE && sizeof(kc_tracker) == KC_TRACKER_SIZE &&
        sizeof(kc_csv) == KC_CSV_SIZE);
}

/* Robots: construction, read-back, every refusal leaves the robot unchanged. */
static void test_robot(void) {
  kc_joint_row rows[KC_JOINTS], back[KC_JOINTS], before[KC_JOINTS], bad[KC_JOINTS];
  kc_frame base, base_back;
  float tool_back[3], xyz[3], rot[9];
  static const float not_rotation[9] = {2, 0, 0, 0, 1, 0, 0, 0, 1};
  static const float rot_z90[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  static const float origin[3] = {100.0f, -50.0f, 20.0f};
  static kc_robot never;

  rows_of(ROWS, rows);
  EXPECT(kc_robot_init(&nominal, 6, rows, NULL, TOOL), KC_OK);
  EXPECT(kc_robot_rows(&nominal, back, &base_back, tool_back), KC_OK);
  CHECK(memcmp(rows, back, sizeof rows) == 0);
  CHECK(base_back.xyz_mm[0] == 0.0f && base_back.rpy_rad[2] == 0.0f);
  CHECK(tool_back[0] == 40.0f && tool_back[1] == 30.0f && tool_back[2] == 120.0f);

  /* A base from roll, pitch, yaw reads back as the same angles. */
  memset(&base, 0, sizeof base);
  base.xyz_mm[0] = 1000.0f;
  base.rpy_rad[0] = 0.1f;
  base.rpy_rad[1] = -0.2f;
  base.rpy_rad[2] = 0.3f;
  EXPECT(kc_robot_init(&scratch, 6, rows, &base, TOOL), KC_OK);
  EXPECT(kc_robot_rows(&scratch, back, &base_back, NULL), KC_OK);
  CHECK(fabsf(base_back.rpy_rad[0] - 0.1f) < 1e-6f && fabsf(base_back.rpy_rad[1] + 0.2f) < 1e-6f &&
        fabsf(base_back.rpy_rad[2] - 0.3f) < 1e-6f && base_back.xyz_mm[0] == 1000.0f);

  /* Refusals: the robot keeps its rows. */
  EXPECT(kc_robot_rows(&nominal, before, NULL, NULL), KC_OK);
  EXPECT(kc_robot_init(NULL, 6, rows, NULL, TOOL), KC_NULL_POINTER);
  EXPECT(kc_robot_init(&nominal, 6, NULL, NULL, TOOL), KC_NULL_POINTER);
  memcpy(bad, rows, sizeof bad);
  bad[3].d_mm = NAN;
  EXPECT(kc_robot_init(&nominal, 6, bad, NULL, TOOL), KC_NOT_FINITE);
  memcpy(bad, rows, sizeof bad);
  bad[1].lower_rad = 1.0f;
  bad[1].upper_rad = -1.0f;
  EXPECT(kc_robot_init(&nominal, 6, bad, NULL, TOOL), KC_INVALID_ROBOT);
  memcpy(bad, rows, sizeof bad);
  bad[2].a_mm = 1e7f; /* 10 km */
  EXPECT(kc_robot_init(&nominal, 6, bad, NULL, TOOL), KC_INVALID_ROBOT);
  base.rpy_rad[1] = INFINITY;
  EXPECT(kc_robot_init(&nominal, 6, rows, &base, TOOL), KC_NOT_FINITE);
  EXPECT(kc_robot_set_base(&nominal, origin, not_rotation), KC_INVALID_ROBOT);
  EXPECT(kc_robot_set_base(&nominal, origin, NULL), KC_NULL_POINTER);
  EXPECT(kc_robot_set_row(&nominal, 6, &rows[0]), KC_INVALID_ARGUMENT);
  EXPECT(kc_robot_set_row(&nominal, 2, &bad[2]), KC_INVALID_ROBOT);
  EXPECT(kc_robot_set_coupling(&nominal, 2, 2, 1.0f), KC_INVALID_ROBOT);
  EXPECT(kc_robot_set_coupling(&nominal, 2, 9, 1.0f), KC_INVALID_ROBOT);
  EXPECT(kc_robot_set_coupling(&nominal, 2, 1, NAN), KC_NOT_FINITE);
  EXPECT(kc_robot_rows(&nominal, back, &base_back, NULL), KC_OK);
  CHECK(memcmp(before, back, sizeof back) == 0);
  CHECK(base_back.xyz_mm[0] == 0.0f && base_back.rpy_rad[0] == 0.0f);
  EXPECT(kc_robot_rows(&never, back, NULL, NULL), KC_NOT_INITIALIZED);
  EXPECT(kc_robot_rows(&nominal, NULL, NULL, NULL), KC_NULL_POINTER);

  /* A rotation matrix base reads back exactly. */
  EXPECT(kc_robot_copy(&scratch, &nominal), KC_OK);
  EXPECT(kc_robot_set_base(&scratch, origin, rot_z90), KC_OK);
  EXPECT(kc_robot_base(&scratch, xyz, rot), KC_OK);
  CHECK(memcmp(rot, rot_z90, sizeof rot) == 0 && memcmp(xyz, origin, sizeof xyz) == 0);
}

/* Forward kinematics against the library's f64 values, couplings, the Jacobian. */
static void test_fk(const double *fk_expected, size_t n_expected) {
  float q[KC_JOINTS], p[3], p2[3], rot[9], jac[3 * 24], jac2[3 * 24];
  kc_param mdh[24], bad_param;
  size_t k;
  int j;
  float worst = 0.0f;
  static kc_fk never;

  EXPECT(kc_fk_init(&fk), KC_OK);
  for (k = 0; k < n_expected; k++) {
    float want[3];
    for (j = 0; j < KC_JOINTS; j++) q[j] = (float)((Q_MID_DEG[j] + 10.0 * (double)k - 15.0 * j) * DEG);
    EXPECT(kc_fk_point(&fk, &nominal, q, p), KC_OK);
    for (j = 0; j < 3; j++) want[j] = (float)fk_expected[3 * k + (size_t)j];
    if (dist3(p, want) > worst) worst = dist3(p, want);
    /* The pose call gives the same point and a rotation. */
    EXPECT(kc_fk_pose(&fk, &nominal, q, p2, rot), KC_OK);
    CHECK(memcmp(p, p2, sizeof p) == 0);
    CHECK(fabsf(rot[0] * rot[0] + rot[3] * rot[3] + rot[6] * rot[6] - 1.0f) < 1e-5f);
  }
  CHECK(n_expected == 4 && worst < 2e-3f); /* f32 vs the library's f64: within 2 µm */

  /* The FANUC J3 coupling: the coupled robot at q is the plain one at q3 + q2. */
  EXPECT(kc_robot_copy(&scratch, &nominal), KC_OK);
  EXPECT(kc_robot_set_coupling(&scratch, 2, 1, 1.0f), KC_OK);
  EXPECT(kc_fk_point(&fk, &scratch, q, p), KC_OK);
  q[2] += q[1];
  EXPECT(kc_fk_point(&fk, &nominal, q, p2), KC_OK);
  CHECK(dist3(p, p2) < 1e-3f);
  EXPECT(kc_robot_set_coupling(&scratch, 2, 1, 1.0f), KC_INVALID_ROBOT); /* twice */

  /* Jacobian: the column of a2 against a finite difference of the model. */
  EXPECT(kc_params_mdh(mdh), KC_OK);
  CHECK(mdh[0].kind == KC_PARAM_ALPHA && mdh[0].joint == 0 && mdh[23].kind == KC_PARAM_D &&
        mdh[23].joint == 5);
  random_q(q);
  EXPECT(kc_fk_point(&fk, &nominal, q, p), KC_OK);
  EXPECT(kc_fk_jacobian(&fk, &nominal, mdh, 24, jac, 3 * 24), KC_OK);
  {
    kc_joint_row rows[KC_JOINTS];
    float h = 0.5f;
    EXPECT(kc_robot_rows(&nominal, rows, NULL, NULL), KC_OK);
    rows[2].a_mm += h;
    EXPECT(kc_robot_copy(&scratch, &nominal), KC_OK);
    EXPECT(kc_robot_set_row(&scratch, 2, &rows[2]), KC_OK);
    EXPECT(kc_fk_point(&fk, &scratch, q, p2), KC_OK);
    /* a of joint 2 (0-based) is column 4*2+1. */
    for (j = 0; j < 3; j++) CHECK(fabsf((p2[j] - p[j]) / h - jac[3 * 9 + j]) < 2e-3f);
    EXPECT(kc_fk_point(&fk, &nominal, q, p), KC_OK);
  }
  /* A NaN or infinite reading: KC_NOT_FINITE and a non-finite point (the workspace then holds
   * no pose: compute again). The other refusals leave the workspace's pose: the Jacobian is
   * the same after them. */
  {
    float q_bad[KC_JOINTS];
    memcpy(q_bad, q, sizeof q_bad);
    q_bad[4] = NAN;
    EXPECT(kc_fk_point(&fk, &nominal, q_bad, p2), KC_NOT_FINITE);
    CHECK(isnan(p2[0]) || isnan(p2[1]) || isnan(p2[2]));
    q_bad[4] = -INFINITY;
    EXPECT(kc_fk_pose(&fk, &nominal, q_bad, p2, rot), KC_NOT_FINITE);
    q_bad[4] = 1e30f; /* finite but absurd: the library clamps it, a finite point */
    EXPECT(kc_fk_point(&fk, &nominal, q_bad, p2), KC_OK);
    EXPECT(kc_fk_point(&fk, &nominal, q, p), KC_OK);
  }
  EXPECT(kc_fk_point(&fk, &nominal, NULL, p), KC_NULL_POINTER);
  EXPECT(kc_fk_point(&fk, &nominal, q, NULL), KC_NULL_POINTER);
  EXPECT(kc_fk_point(NULL, &nominal, q, p), KC_NULL_POINTER);
  EXPECT(kc_fk_point(&never, &nominal, q, p), KC_NOT_INITIALIZED);
  EXPECT(kc_fk_jacobian(&fk, &nominal, mdh, 24, jac2, 3 * 24 - 1), KC_BUFFER_TOO_SMALL);
  EXPECT(kc_fk_jacobian(&fk, &nominal, mdh, KC_PARAMS_ALL + 1, jac2, 3 * (KC_PARAMS_ALL + 1)), KC_TOO_MANY_PARAMS);
  EXPECT(kc_fk_jacobian(&fk, &nominal, NULL, 24, jac2, 3 * 24), KC_NULL_POINTER);
  bad_param.kind = KC_PARAM_D;
  bad_param.joint = 6;
  EXPECT(kc_fk_jacobian(&fk, &nominal, &bad_param, 1, jac2, 3), KC_INVALID_ARGUMENT);
  bad_param.kind = 99;
  bad_param.joint = 0;
  EXPECT(kc_fk_jacobian(&fk, &nominal, &bad_param, 1, jac2, 3), KC_INVALID_ARGUMENT);
  EXPECT(kc_fk_jacobian(&fk, &nominal, mdh, 24, jac2, 3 * 24), KC_OK);
  CHECK(memcmp(jac, jac2, sizeof jac) == 0);

  /* The converted set gives the same columns. */
  {
    static kc_param_set set, never_set;
    size_t len = 0;
    EXPECT(kc_param_set_init(&set, mdh, 24), KC_OK);
    EXPECT(kc_param_set_len(&set, &len), KC_OK);
    CHECK(len == 24);
    memset(jac2, 0, sizeof jac2);
    EXPECT(kc_fk_jacobian_set(&fk, &nominal, &set, jac2, 3 * 24), KC_OK);
    CHECK(memcmp(jac, jac2, sizeof jac) == 0);
    EXPECT(kc_fk_jacobian_set(&fk, &nominal, &set, jac2, 3 * 24 - 1), KC_BUFFER_TOO_SMALL);
    EXPECT(kc_fk_jacobian_set(&fk, &nominal, &never_set, jac2, 3 * 24), KC_NOT_INITIALIZED);
    EXPECT(kc_param_set_init(&set, &bad_param, 1), KC_INVALID_ARGUMENT);
    EXPECT(kc_param_set_init(&set, mdh, KC_PARAMS_ALL + 1), KC_TOO_MANY_PARAMS);
    EXPECT(kc_param_set_len(&set, &len), KC_OK); /* unchanged by the refusals */
    CHECK(len == 24);
  }

  {
    kc_param full[KC_PARAMS_ALL];
    size_t count = 0;
    EXPECT(kc_params_full(6, 1, full, 10, &count), KC_BUFFER_TOO_SMALL);
    CHECK(count == 33);
    EXPECT(kc_params_full(6, 1, full, KC_PARAMS_ALL, &count), KC_OK);
    CHECK(count == 33 && full[0].kind == KC_PARAM_BASE_X && full[32].kind == KC_PARAM_TOOL_Z);
    EXPECT(kc_params_full(6, 0, full, KC_PARAMS_ALL, &count), KC_OK);
    CHECK(count == 27);
  }
}

/* The true robot: every MDH value off its nominal by a deterministic pattern. */
static void make_truth(void) {
  kc_joint_row rows[KC_JOINTS];
  int j;
  rows_of(ROWS, rows);
  for (j = 0; j < KC_JOINTS; j++) {
    float s = (j % 2) ? 1.0f : -1.0f;
    rows[j].alpha_rad += s * (float)(0.05 * DEG);
    rows[j].a_mm += 0.3f * s + 0.1f * (float)j;
    rows[j].theta_rad += (float)((0.1 - 0.03 * j) * DEG);
    rows[j].d_mm -= 0.4f * s;
  }
  EXPECT(kc_robot_init(&truth, 6, rows, NULL, TOOL), KC_OK);
}

static void measure(kc_measurement *out, size_t n) {
  size_t i;
  for (i = 0; i < n; i++) {
    random_q(out[i].q);
    EXPECT(kc_fk_point(&fk, &truth, out[i].q, out[i].xyz_mm), KC_OK);
  }
}

/* Field by field: the struct has padding, whose bytes the library need not write. */
static int same_progress(const kc_lm_progress *a, const kc_lm_progress *b) {
  return a->iteration == b->iteration && a->evaluations == b->evaluations &&
         memcmp(&a->cost, &b->cost, sizeof a->cost) == 0 && a->stopped == b->stopped &&
         a->converged == b->converged;
}

/* Runs `l` to its end in slices of 5 poses; saves a snapshot into `snap` once the run reaches
 * `snap_at` iterations (when `snap` is not NULL). Returns the number of step calls. */
static int run_lm(kc_lm *l, kc_lm_progress *end, uint8_t *snap, size_t *snap_len,
                  uint32_t snap_at) {
  kc_lm_progress p;
  int calls = 0;
  memset(&p, 0, sizeof p);
  while (calls < 100000) {
    if (snap != NULL && *snap_len == 0 && p.iteration >= snap_at) {
      EXPECT(kc_lm_save(l, snap, sizeof flash, snap_len), KC_OK);
    }
    EXPECT(kc_lm_step(l, id_data, N_ID, 5, &p), KC_OK);
    calls++;
    if (p.stopped != KC_LM_RUNNING) break;
  }
  *end = p;
  return calls;
}

static void test_lm(void) {
  kc_param mdh[24], unid[24], too_many[KC_LM_MAX_PARAMS + 1];
  kc_lm_progress end, end2, p;
  kc_lm_config cfg;
  kc_joint_row got[KC_JOINTS], want[KC_JOINTS], got2[KC_JOINTS];
  size_t snap_len = 0, n_unid = 0, size = 0, written = 0, len2 = 0, i;
  float rms_nominal = 0, rms_model = 0, worst_val = 0;
  kc_measurement bad[N_ID];
  static kc_lm never;

  make_truth();
  measure(id_data, N_ID);
  measure(val_data, N_VAL);
  EXPECT(kc_params_mdh(mdh), KC_OK);
  EXPECT(kc_rms_error(&nominal, id_data, N_ID, &rms_nominal), KC_OK);
  CHECK(rms_nominal > 1.0f);

  /* A full run with a snapshot halfway (after 2 iterations). */
  EXPECT(kc_lm_init(&lm, &nominal, mdh, 24, NULL), KC_OK);
  run_lm(&lm, &end, flash, &snap_len, 2);
  CHECK(end.converged == 1 && end.iteration > 2 && snap_len > 0);
  EXPECT(kc_lm_snapshot_size(&lm, &size), KC_OK);
  CHECK(size == snap_len);
  EXPECT(kc_lm_robot(&lm, &model), KC_OK);
  EXPECT(kc_rms_error(&model, id_data, N_ID, &rms_model), KC_OK);
  CHECK(rms_model < 1e-2f);
  for (i = 0; i < N_VAL; i++) {
    float pm[3];
    EXPECT(kc_fk_point(&fk, &model, val_data[i].q, pm), KC_OK);
    if (dist3(pm, val_data[i].xyz_mm) > worst_val) worst_val = dist3(pm, val_data[i].xyz_mm);
  }
  CHECK(worst_val < 1e-2f); /* held-out poses predicted to 10 µm (noise-free data) */
  fprintf(stderr, "c: LM %u iterations, rms %.3g mm -> %.3g mm, held-out worst %.3g mm\n",
          (unsigned)end.iteration, (double)rms_nominal, (double)rms_model, (double)worst_val);

  /* Identifiable parameters recover the truth. */
  EXPECT(kc_lm_unidentifiable(&lm, unid, 24, &n_unid), KC_OK);
  CHECK(n_unid < 24);
  if (n_unid > 0) {
    size_t n2 = 0;
    EXPECT(kc_lm_unidentifiable(&lm, unid, 0, &n2), KC_BUFFER_TOO_SMALL);
    CHECK(n2 == n_unid);
  }
  EXPECT(kc_robot_rows(&model, got, NULL, NULL), KC_OK);
  EXPECT(kc_robot_rows(&truth, want, NULL, NULL), KC_OK);
  {
    int j;
    for (j = 0; j < KC_JOINTS; j++) {
      fprintf(stderr, "c: joint %d: d_alpha %.2e rad, d_a %.2e mm, d_theta %.2e rad, d_d %.2e mm\n", j,
              (double)(got[j].alpha_rad - want[j].alpha_rad), (double)(got[j].a_mm - want[j].a_mm),
              (double)(got[j].theta_rad - want[j].theta_rad), (double)(got[j].d_mm - want[j].d_mm));
    }
    for (i = 0; i < n_unid; i++)
      fprintf(stderr, "c: unidentifiable: kind %u joint %u\n", unid[i].kind, unid[i].joint);
    /* Every parameter the solver estimated recovers the truth (angles to 1e-4 rad, 10x below
     * the perturbation; lengths to 0.1 mm), except d of joint 2, which also absorbs the d of
     * joint 1 it is parallel to (held, unidentifiable): their sum recovers the truth. The held
     * parameters keep their nominal values exactly. */
    {
      kc_joint_row nom[KC_JOINTS];
      EXPECT(kc_robot_rows(&nominal, nom, NULL, NULL), KC_OK);
      for (j = 0; j < KC_JOINTS; j++) {
        int held[4] = {0, 0, 0, 0}, k;
        const float g[4] = {got[j].alpha_rad, got[j].a_mm, got[j].theta_rad, got[j].d_mm};
        const float w[4] = {want[j].alpha_rad, want[j].a_mm, want[j].theta_rad, want[j].d_mm};
        const float n0[4] = {nom[j].alpha_rad, nom[j].a_mm, nom[j].theta_rad, nom[j].d_mm};
        for (i = 0; i < n_unid; i++)
          if (unid[i].joint == j && unid[i].kind >= KC_PARAM_ALPHA && unid[i].kind <= KC_PARAM_D)
            held[unid[i].kind - KC_PARAM_ALPHA] = 1;
        for (k = 0; k < 4; k++) {
          float tol = (k == 1 || k == 3) ? 0.1f : 1e-4f;
          if (held[k]) {
            CHECK(g[k] == n0[k]);
          } else if (!(j == 2 && k == 3)) {
            CHECK(fabsf(g[k] - w[k]) < tol);
          }
        }
      }
      CHECK(n_unid == 2);
      CHECK(fabsf((got[1].d_mm + got[2].d_mm) - (want[1].d_mm + want[2].d_mm)) < 0.1f);
    }
  }

  /* Power lost at the snapshot: a fresh solver restored from it ends bit-identical. */
  EXPECT(kc_lm_init(&lm2, &nominal, mdh, 24, NULL), KC_OK);
  EXPECT(kc_lm_restore(&lm2, flash, snap_len), KC_OK);
  run_lm(&lm2, &end2, NULL, NULL, 0);
  CHECK(same_progress(&end, &end2));
  EXPECT(kc_lm_robot(&lm2, &scratch), KC_OK);
  EXPECT(kc_robot_rows(&scratch, got2, NULL, NULL), KC_OK);
  CHECK(memcmp(got, got2, sizeof got) == 0);

  /* Snapshot refusals leave the solver as it was (its own snapshot is unchanged). */
  EXPECT(kc_lm_save(&lm2, flash2, sizeof flash2, &len2), KC_OK);
  EXPECT(kc_lm_save(&lm2, flash2, 10, &written), KC_BUFFER_TOO_SMALL);
  CHECK(written == len2);
  EXPECT(kc_lm_save(&lm2, NULL, 0, &written), KC_BUFFER_TOO_SMALL);
  CHECK(written == len2);
  EXPECT(kc_lm_save(&lm2, flash2, sizeof flash2, NULL), KC_NULL_POINTER);
  flash[snap_len / 2] ^= 0x40; /* corrupted: the CRC refuses it */
  EXPECT(kc_lm_restore(&lm2, flash, snap_len), KC_SNAPSHOT_INVALID);
  flash[snap_len / 2] ^= 0x40;
  EXPECT(kc_lm_restore(&lm2, flash, snap_len - 1), KC_SNAPSHOT_INVALID); /* truncated */
  EXPECT(kc_lm_restore(&lm2, flash, 3), KC_SNAPSHOT_INVALID);
  EXPECT(kc_lm_restore(&lm2, NULL, 0), KC_SNAPSHOT_INVALID);
  EXPECT(kc_lm_restore(&lm2, NULL, 10), KC_NULL_POINTER);
  EXPECT(kc_lm_save(&lm2, flash2 + 8192, 8192, &written), KC_OK);
  CHECK(written == len2 && memcmp(flash2, flash2 + 8192, len2) == 0);
  /* A snapshot of a solver with other parameters does not fit. */
  EXPECT(kc_lm_init(&lm_bad, &nominal, mdh, 12, NULL), KC_OK);
  EXPECT(kc_lm_restore(&lm_bad, flash, snap_len), KC_SNAPSHOT_INVALID);

  /* Step refusals. */
  EXPECT(kc_lm_init(&lm_bad, &nominal, mdh, 24, NULL), KC_OK);
  memcpy(bad, id_data, sizeof bad);
  bad[7].xyz_mm[1] = NAN;
  EXPECT(kc_lm_step(&lm_bad, bad, N_ID, 5, &p), KC_NOT_FINITE);
  EXPECT(kc_lm_step(&lm_bad, id_data, 7, 5, &p), KC_TOO_FEW_MEASUREMENTS); /* 21 < 24 */
  EXPECT(kc_lm_step(&lm_bad, id_data, 0, 5, &p), KC_TOO_FEW_MEASUREMENTS);
  EXPECT(kc_lm_step(&lm_bad, NULL, N_ID, 5, &p), KC_NULL_POINTER);
  EXPECT(kc_lm_step(&lm_bad, id_data, N_ID, 5, NULL), KC_NULL_POINTER);
  EXPECT(kc_lm_step(&lm_bad, id_data, N_ID, 5, &p), KC_OK);
  CHECK(p.stopped == KC_LM_RUNNING && p.iteration == 0);
  EXPECT(kc_lm_step(&lm_bad, id_data, N_ID - 1, 5, &p), KC_DATA_CHANGED);
  EXPECT(kc_lm_step(&never, id_data, N_ID, 5, &p), KC_NOT_INITIALIZED);
  EXPECT(kc_lm_get_progress(&never, &p), KC_NOT_INITIALIZED);

  /* Init refusals (checked before the handle is written: lm2 keeps its finished run). */
  memset(too_many, 0, sizeof too_many);
  for (i = 0; i < KC_LM_MAX_PARAMS + 1; i++) too_many[i] = mdh[i % 24];
  EXPECT(kc_lm_init(&lm2, &nominal, too_many, KC_LM_MAX_PARAMS + 1, NULL), KC_TOO_MANY_PARAMS);
  EXPECT(kc_lm_init(&lm2, &nominal, mdh, 0, NULL), KC_INVALID_ARGUMENT);
  too_many[3].kind = 77;
  EXPECT(kc_lm_init(&lm2, &nominal, too_many, 24, NULL), KC_INVALID_ARGUMENT);
  EXPECT(kc_lm_config_default(&cfg), KC_OK);
  CHECK(cfg.max_iterations == 100 && cfg.max_analyses == 8 && cfg.keep_curvature == 0);
  cfg.initial_damping = 0.0f;
  EXPECT(kc_lm_init(&lm2, &nominal, mdh, 24, &cfg), KC_INVALID_ARGUMENT);
  cfg.initial_damping = NAN;
  EXPECT(kc_lm_init(&lm2, &nominal, mdh, 24, &cfg), KC_NOT_FINITE);
  EXPECT(kc_lm_init(&lm2, &never_robot, mdh, 24, NULL), KC_NOT_INITIALIZED);
  EXPECT(kc_lm_init(&lm2, NULL, mdh, 24, NULL), KC_NULL_POINTER);
  EXPECT(kc_lm_get_progress(&lm2, &p), KC_OK);
  CHECK(same_progress(&p, &end));
}

/* The firmware's usual case: the data are in the tracker's frame, whose pose (and the tool
 * point) is known only roughly. LM over the full set (base, rows, tool: 33 parameters) from the
 * rough values recovers the base and the tool where they are identifiable, and predicts
 * held-out poses. */
static void test_lm_full(void) {
  static kc_robot start, true_cell, fitted;
  static kc_lm_full full_lm;
  static kc_lm mdh_lm;
  static kc_measurement id[N_ID], val[N_VAL];
  kc_joint_row rows[KC_JOINTS];
  kc_param full[KC_PARAMS_ALL];
  const kc_frame base_true = {{1500.0f, -300.0f, 200.0f}, {0.004f, -0.003f, 0.7f}};
  const kc_frame base_guess = {{1497.0f, -298.0f, 203.5f}, {0.0f, 0.0f, 0.69f}};
  const float tool_guess[3] = {41.0f, 29.2f, 121.0f};
  float base_got[3], rot_got[9], rot_true[9], tool_got[3], rms = 0, worst = 0, pm[3];
  float xyz_true[3];
  kc_lm_progress end, end24;
  size_t count = 0, i;

  EXPECT(kc_robot_rows(&truth, rows, NULL, NULL), KC_OK);
  EXPECT(kc_robot_init(&true_cell, 6, rows, &base_true, TOOL), KC_OK);
  for (i = 0; i < N_ID; i++) {
    random_q(id[i].q);
    EXPECT(kc_fk_point(&fk, &true_cell, id[i].q, id[i].xyz_mm), KC_OK);
  }
  for (i = 0; i < N_VAL; i++) {
    random_q(val[i].q);
    EXPECT(kc_fk_point(&fk, &true_cell, val[i].q, val[i].xyz_mm), KC_OK);
  }
  rows_of(ROWS, rows);
  EXPECT(kc_robot_init(&start, 6, rows, &base_guess, tool_guess), KC_OK);
  EXPECT(kc_params_full(6, 1, full, KC_PARAMS_ALL, &count), KC_OK);
  CHECK(count == 33 && count > KC_LM_MAX_PARAMS && count <= KC_LM_FULL_MAX_PARAMS);
  EXPECT(kc_lm_init(&mdh_lm, &start, full, count, NULL), KC_TOO_MANY_PARAMS);
  EXPECT(kc_lm_full_init(&full_lm, &start, full, count, NULL), KC_OK);
  for (i = 0; i < 100000; i++) {
    EXPECT(kc_lm_full_step(&full_lm, id, N_ID, 5, &end), KC_OK);
    if (end.stopped != KC_LM_RUNNING) break;
  }
  CHECK(end.converged == 1);
  {
    /* Its snapshot restores into a fresh kc_lm_full, not into a kc_lm. */
    static kc_lm_full again;
    static uint8_t snap[16384];
    size_t len = 0;
    kc_lm_progress p2;
    EXPECT(kc_lm_full_save(&full_lm, snap, sizeof snap, &len), KC_OK);
    EXPECT(kc_lm_full_init(&again, &start, full, count, NULL), KC_OK);
    EXPECT(kc_lm_full_restore(&again, snap, len), KC_OK);
    EXPECT(kc_lm_full_get_progress(&again, &p2), KC_OK);
    CHECK(p2.iteration == end.iteration && p2.evaluations == end.evaluations &&
          p2.cost == end.cost && p2.stopped == end.stopped && p2.converged == end.converged);
    if (p2.iteration != end.iteration || p2.cost != end.cost || p2.stopped != end.stopped)
      fprintf(stderr, "c: restored %u %g %u, ran %u %g %u\n", (unsigned)p2.iteration, (double)p2.cost,
              (unsigned)p2.stopped, (unsigned)end.iteration, (double)end.cost, (unsigned)end.stopped);
    EXPECT(kc_lm_restore(&mdh_lm, snap, len), KC_NOT_INITIALIZED);
  }
  EXPECT(kc_lm_full_robot(&full_lm, &fitted), KC_OK);
  EXPECT(kc_rms_error(&fitted, id, N_ID, &rms), KC_OK);
  CHECK(rms < 1e-2f);
  for (i = 0; i < N_VAL; i++) {
    EXPECT(kc_fk_point(&fk, &fitted, val[i].q, pm), KC_OK);
    if (dist3(pm, val[i].xyz_mm) > worst) worst = dist3(pm, val[i].xyz_mm);
  }
  CHECK(worst < 2e-2f);
  /* The same data and start without the base and tool parameters (the 24 of the MDH set):
   * the rows cannot absorb a base off by millimetres, so held-out poses stay far off. */
  {
    kc_param mdh[24];
    float worst24 = 0;
    EXPECT(kc_params_mdh(mdh), KC_OK);
    EXPECT(kc_lm_init(&mdh_lm, &start, mdh, 24, NULL), KC_OK);
    for (i = 0; i < 100000; i++) {
      EXPECT(kc_lm_step(&mdh_lm, id, N_ID, 5, &end24), KC_OK);
      if (end24.stopped != KC_LM_RUNNING) break;
    }
    EXPECT(kc_lm_robot(&mdh_lm, &scratch), KC_OK);
    for (i = 0; i < N_VAL; i++) {
      EXPECT(kc_fk_point(&fk, &scratch, val[i].q, pm), KC_OK);
      if (dist3(pm, val[i].xyz_mm) > worst24) worst24 = dist3(pm, val[i].xyz_mm);
    }
    CHECK(worst24 > 50.0f * worst);
    fprintf(stderr, "c: the 24 MDH parameters alone: held-out worst %.3g mm\n", (double)worst24);
  }
  EXPECT(kc_robot_base(&fitted, base_got, rot_got), KC_OK);
  EXPECT(kc_robot_init(&scratch, 6, rows, &base_true, TOOL), KC_OK);
  EXPECT(kc_robot_base(&scratch, xyz_true, rot_true), KC_OK);
  EXPECT(kc_robot_rows(&fitted, rows, NULL, tool_got), KC_OK);
  fprintf(stderr,
          "c: LM over %u parameters (base unknown): %u iterations, rms %.3g mm, held-out worst "
          "%.3g mm, base origin off by (%.3g, %.3g, %.3g) mm\n",
          (unsigned)count, (unsigned)end.iteration, (double)rms, (double)worst,
          (double)(base_got[0] - xyz_true[0]), (double)(base_got[1] - xyz_true[1]),
          (double)(base_got[2] - xyz_true[2]));
}

/* Compensation on the true robot of targets the nominal model plans. */
static void test_compensate(void) {
  float qn[KC_JOINTS], p[3], rot[9], bad_q[KC_JOINTS];
  kc_target t, bad_t;
  kc_solution s, before;
  kc_compensate_config cfg;
  int j;
  float raw;

  for (j = 0; j < KC_JOINTS; j++) qn[j] = (float)(Q_MID_DEG[j] * DEG);
  EXPECT(kc_fk_pose(&fk, &nominal, qn, t.xyz_mm, t.rot), KC_OK);
  t.kind = KC_TARGET_POSE;
  EXPECT(kc_fk_point(&fk, &truth, qn, p), KC_OK);
  raw = dist3(p, t.xyz_mm);
  CHECK(raw > 0.5f);
  EXPECT(kc_compensate(&truth, &t, qn, NULL, &s), KC_OK);
  CHECK(s.status == KC_SOLUTION_OK && s.iterations >= 1);
  EXPECT(kc_fk_pose(&fk, &truth, s.q, p, rot), KC_OK);
  CHECK(dist3(p, t.xyz_mm) < 2e-3f && s.position_error_mm < 2e-3f);
  for (j = 0; j < 9; j++) CHECK(fabsf(rot[j] - t.rot[j]) < 1e-4f);

  /* A point target, explicit default settings: the same kind of answer. */
  t.kind = KC_TARGET_POINT;
  EXPECT(kc_compensate_config_default(&cfg), KC_OK);
  CHECK(cfg.iterations == 8 && cfg.orientation_scale_mm == 0.0f);
  EXPECT(kc_compensate(&truth, &t, qn, &cfg, &s), KC_OK);
  EXPECT(kc_fk_point(&fk, &truth, s.q, p), KC_OK);
  CHECK(dist3(p, t.xyz_mm) < 2e-3f && s.orientation_error_rad == 0.0f);

  /* Out of reach: the best safe command, inside the step box around the seed. */
  t.xyz_mm[0] += 5000.0f;
  EXPECT(kc_compensate(&truth, &t, qn, NULL, &s), KC_COMPENSATE_FAILED);
  CHECK(s.status == KC_SOLUTION_UNREACHABLE || s.status == KC_SOLUTION_LIMITED);
  for (j = 0; j < KC_JOINTS; j++) CHECK(fabsf(s.q[j] - qn[j]) <= cfg.max_step_rad * 1.0001f);
  t.xyz_mm[0] -= 5000.0f;

  /* Refusals: nothing computed, the output untouched. */
  before = s;
  memcpy(bad_q, qn, sizeof bad_q);
  bad_q[2] = NAN;
  EXPECT(kc_compensate(&truth, &t, bad_q, NULL, &s), KC_NOT_FINITE);
  bad_t = t;
  bad_t.xyz_mm[1] = INFINITY;
  EXPECT(kc_compensate(&truth, &bad_t, qn, NULL, &s), KC_NOT_FINITE);
  bad_t = t;
  bad_t.xyz_mm[0] = 1e9f; /* a unit mistake, not a target */
  EXPECT(kc_compensate(&truth, &bad_t, qn, NULL, &s), KC_INVALID_ARGUMENT);
  bad_t = t;
  bad_t.kind = 7;
  EXPECT(kc_compensate(&truth, &bad_t, qn, NULL, &s), KC_INVALID_ARGUMENT);
  bad_t = t;
  bad_t.kind = KC_TARGET_POSE;
  bad_t.rot[0] = NAN;
  EXPECT(kc_compensate(&truth, &bad_t, qn, NULL, &s), KC_NOT_FINITE);
  cfg.iterations = 0;
  EXPECT(kc_compensate(&truth, &t, qn, &cfg, &s), KC_INVALID_ARGUMENT);
  cfg.iterations = 300;
  EXPECT(kc_compensate(&truth, &t, qn, &cfg, &s), KC_INVALID_ARGUMENT);
  cfg.iterations = 8;
  cfg.max_step_rad = -1.0f;
  EXPECT(kc_compensate(&truth, &t, qn, &cfg, &s), KC_INVALID_ARGUMENT);
  cfg.max_step_rad = NAN;
  EXPECT(kc_compensate(&truth, &t, qn, &cfg, &s), KC_NOT_FINITE);
  EXPECT(kc_compensate(NULL, &t, qn, NULL, &s), KC_NULL_POINTER);
  EXPECT(kc_compensate(&never_robot, &t, qn, NULL, &s), KC_NOT_INITIALIZED);
  EXPECT(kc_compensate(&truth, &t, qn, NULL, NULL), KC_NULL_POINTER);
  CHECK(memcmp(&s, &before, sizeof s) == 0);
}

/* The tracker follows a 20-tick trajectory of pose targets with the identified model. */
static void test_tracker(void) {
  float qn[KC_JOINTS], p[3], q_before[KC_JOINTS];
  kc_target t;
  kc_solution s;
  kc_compensate_config cfg;
  int k, j, ok = 0;
  float worst = 0.0f, worst_raw = 0.0f;
  static kc_tracker never;

  EXPECT(kc_tracker_init(&tracker, NULL), KC_OK);
  t.kind = KC_TARGET_POSE;
  for (k = 0; k < 20; k++) {
    for (j = 0; j < KC_JOINTS; j++)
      qn[j] = (float)((Q_MID_DEG[j] + 1.5 * sin(6.283185307179586 * k / 20.0 + 0.7 * j)) * DEG);
    EXPECT(kc_fk_pose(&fk, &nominal, qn, t.xyz_mm, t.rot), KC_OK);
    if (kc_tracker_next(&tracker, &model, &t, qn, &s) == KC_OK) ok++;
    EXPECT(kc_fk_point(&fk, &truth, s.q, p), KC_OK);
    if (dist3(p, t.xyz_mm) > worst) worst = dist3(p, t.xyz_mm);
    EXPECT(kc_fk_point(&fk, &truth, qn, p), KC_OK);
    if (dist3(p, t.xyz_mm) > worst_raw) worst_raw = dist3(p, t.xyz_mm);
  }
  fprintf(stderr, "c: tracker: worst %.3g mm on the true robot (uncompensated %.3g mm)\n",
          (double)worst, (double)worst_raw);
  CHECK(ok == 20 && worst < 1e-2f && worst_raw > 100.0f * worst);

  /* Refusals leave the tracker as it was: the next tick gives the same command. */
  memcpy(q_before, s.q, sizeof q_before);
  qn[0] = NAN;
  EXPECT(kc_tracker_next(&tracker, &model, &t, qn, &s), KC_NOT_FINITE);
  t.kind = 5;
  EXPECT(kc_tracker_next(&tracker, &model, &t, qn, &s), KC_INVALID_ARGUMENT);
  t.kind = KC_TARGET_POSE;
  EXPECT(kc_tracker_next(&never, &model, &t, qn, &s), KC_NOT_INITIALIZED);
  EXPECT(kc_tracker_follow(&tracker, &model, &t, &s), KC_OK); /* from the last command */
  for (j = 0; j < KC_JOINTS; j++) CHECK(fabsf(s.q[j] - q_before[j]) < 1e-3f);
  EXPECT(kc_tracker_reset(&tracker), KC_OK);
  EXPECT(kc_tracker_follow(&tracker, &model, &t, &s), KC_INVALID_ARGUMENT); /* no command */
  EXPECT(kc_tracker_start(&tracker, &model, q_before), KC_OK);
  EXPECT(kc_tracker_follow(&tracker, &model, &t, &s), KC_OK);
  qn[0] = NAN;
  EXPECT(kc_tracker_start(&tracker, &model, qn), KC_NOT_FINITE);
  EXPECT(kc_compensate_config_default(&cfg), KC_OK);
  cfg.accept_mm = 0.0f;
  EXPECT(kc_tracker_init(&tracker, &cfg), KC_INVALID_ARGUMENT);
  EXPECT(kc_tracker_follow(&tracker, &model, &t, &s), KC_OK); /* still initialised */
}

/* Entry point for host-tests/tests/library/c_abi.rs: `fk_expected` holds the library's f64 points of
 * the nominal arm at the 4 poses test_fk uses (3 per pose). Returns the failed checks. */
int kc_host_test_main(const double *fk_expected, size_t n_expected) {
  failures = 0;
  checks = 0;
  test_status_messages();
  test_robot();
  test_fk(fk_expected, n_expected);
  test_lm();
  test_lm_full();
  test_compensate();
  test_tracker();
  kc_csv_test();
  fprintf(stderr, "c: %d checks, %d failed\n", checks, failures);
  return failures;
}
