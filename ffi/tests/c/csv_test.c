/* The C ABI's CSV reader from C (part of the host test: kc_csv_test is called by
 * host_test.c's kc_host_test_main): records through the read callback in small chunks, the
 * extra columns, and every error (a bad cell, a missing column, empty input, a failing read). */
#include "check.h"
#include "kinecal.h"

#include <math.h>
#include <string.h>

#define N_CSV_EXTRAS 2

static kc_csv csv;

/* CSV from memory through the read callback, at most `chunk` bytes per read. */
typedef struct mem_reader {
  const char *data;
  size_t len, pos, chunk;
  int fail_at; /* read calls before failing (-1 = never) */
} mem_reader;

static size_t mem_read(void *ctx, uint8_t *buf, size_t len) {
  mem_reader *m = (mem_reader *)ctx;
  size_t n = m->len - m->pos;
  if (m->fail_at == 0) {
    m->fail_at = -1; /* once */
    return (size_t)-1;
  }
  if (m->fail_at > 0) m->fail_at--;
  if (n > len) n = len;
  if (n > m->chunk) n = m->chunk;
  memcpy(buf, m->data + m->pos, n);
  m->pos += n;
  return n;
}

void kc_csv_test(void) {
  static const char text[] =
      "# measurements\n"
      "q1,q2,q3,q4,q5,q6,x,y,z,set,temp_c\n"
      "10,20,30,40,50,60,1000.5,-200.25,300,0,21.5\n"
      "0,0,0,0,0,0,1,2,3,1,\n"
      "1,2,x,4,5,6,1,2,3,0,20\n"
      "\n"
      "-90,45.5,0,0,0,180,0.125,0,-7,1,22.75\n";
  mem_reader m = {text, sizeof text - 1, 0, 7, -1};
  kc_measurement rec, want;
  kc_csv_record raw;
  kc_csv_error e;
  double extras[N_CSV_EXTRAS], big_extras[KC_CSV_MAX_EXTRAS];
  static const double q_deg[KC_JOINTS] = {10, 20, 30, 40, 50, 60};
  static const double xyz[3] = {1000.5, -200.25, 300};
  size_t idx = 99, count = 0;
  uint32_t line = 0;
  static kc_csv never;

  EXPECT(kc_csv_init(&csv, mem_read, &m), KC_OK);
  EXPECT(kc_csv_extra_count(&csv, &count), KC_OK);
  CHECK(count == 2);
  EXPECT(kc_csv_extra_index(&csv, "temp_c", &idx), KC_OK);
  CHECK(idx == 1);
  EXPECT(kc_csv_extra_index(&csv, "pressure", &idx), KC_NOT_FOUND);
  EXPECT(kc_csv_extra_index(&csv, NULL, &idx), KC_NULL_POINTER);
  EXPECT(kc_csv_last_error(&csv, &e), KC_OK);
  CHECK(e.kind == KC_CSV_NONE);

  EXPECT(kc_csv_next(&csv, &rec, extras, N_CSV_EXTRAS, &line), KC_OK);
  EXPECT(kc_measurement_from_deg(q_deg, xyz, &want), KC_OK);
  CHECK(memcmp(&rec, &want, sizeof rec) == 0 && line == 3);
  CHECK(fabsf(rec.q[1] - (float)(20.0 * DEG)) < 1e-7f && rec.xyz_mm[0] == 1000.5f);
  CHECK(extras[0] == 0.0 && extras[1] == 21.5);
  EXPECT(kc_csv_next(&csv, &rec, extras, N_CSV_EXTRAS, &line), KC_OK);
  CHECK(line == 4 && rec.xyz_mm[2] == 3.0f && extras[0] == 1.0 && isnan(extras[1]));
  EXPECT(kc_csv_next(&csv, &rec, extras, N_CSV_EXTRAS, &line), KC_CSV_ERROR);
  CHECK(line == 5);
  EXPECT(kc_csv_last_error(&csv, &e), KC_OK);
  CHECK(e.kind == KC_CSV_NOT_A_NUMBER && e.line == 5 && e.column == 3);
  EXPECT(kc_csv_next(&csv, &rec, NULL, 3, &line), KC_NULL_POINTER);
  EXPECT(kc_csv_next(&csv, NULL, extras, N_CSV_EXTRAS, &line), KC_NULL_POINTER);
  EXPECT(kc_csv_next_raw(&csv, &raw, big_extras, KC_CSV_MAX_EXTRAS), KC_OK);
  CHECK(raw.line == 7 && raw.q_deg[0] == -90.0 && raw.q_deg[1] == 45.5 && raw.q_deg[5] == 180.0 &&
        raw.xyz_mm[0] == 0.125 && raw.xyz_mm[2] == -7.0 && big_extras[1] == 22.75);
  EXPECT(kc_csv_next(&csv, &rec, NULL, 0, NULL), KC_END);
  EXPECT(kc_csv_next(&csv, &rec, NULL, 0, NULL), KC_END);

  /* A header without z. */
  {
    static const char no_z[] = "q1,q2,q3,q4,q5,q6,x,y\n1,2,3,4,5,6,7,8\n";
    mem_reader m2 = {no_z, sizeof no_z - 1, 0, 64, -1};
    EXPECT(kc_csv_init(&csv, mem_read, &m2), KC_CSV_ERROR);
    EXPECT(kc_csv_last_error(&csv, &e), KC_OK);
    CHECK(e.kind == KC_CSV_MISSING_COLUMN && e.line == 1);
    EXPECT(kc_csv_next(&csv, &rec, NULL, 0, NULL), KC_CSV_ERROR);
  }
  /* Empty input. */
  {
    mem_reader m3 = {"", 0, 0, 64, -1};
    EXPECT(kc_csv_init(&csv, mem_read, &m3), KC_CSV_ERROR);
    EXPECT(kc_csv_last_error(&csv, &e), KC_OK);
    CHECK(e.kind == KC_CSV_EMPTY);
  }
  /* The callback fails in the middle of a record: a read error, then the rest reads on. */
  {
    mem_reader m4 = {text, sizeof text - 1, 0, 16, 5};
    kc_status s;
    int records = 0, errors = 0, io = 0, guard = 0;
    EXPECT(kc_csv_init(&csv, mem_read, &m4), KC_OK);
    while ((s = kc_csv_next(&csv, &rec, NULL, 0, NULL)) != KC_END && guard++ < 20) {
      if (s == KC_OK) records++;
      if (s == KC_CSV_ERROR) {
        errors++;
        EXPECT(kc_csv_last_error(&csv, &e), KC_OK);
        if (e.kind == KC_CSV_IO) io++;
      }
    }
    CHECK(io == 1 && errors == 2 && records == 2 && s == KC_END);
  }
  EXPECT(kc_csv_init(&csv, NULL, &m), KC_NULL_POINTER);
  EXPECT(kc_csv_init(NULL, mem_read, &m), KC_NULL_POINTER);
  EXPECT(kc_csv_next(&never, &rec, NULL, 0, NULL), KC_NOT_INITIALIZED);
}
