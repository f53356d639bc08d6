/* The checks of the C host test (host_test.c and csv_test.c): CHECK(cond) and
 * EXPECT(call, status) count every check and print each failure with its file and line. */
#ifndef KC_TEST_CHECK_H
#define KC_TEST_CHECK_H

#include "kinecal.h"

#include <stdio.h>

/* Defined in host_test.c. */
extern int failures;
extern int checks;

#define CHECK(cond)                                                                  \
  do {                                                                               \
    checks++;                                                                        \
    if (!(cond)) {                                                                   \
      fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);       \
      failures++;                                                                    \
    }                                                                                \
  } while (0)

#define EXPECT(call, want)                                                           \
  do {                                                                               \
    kc_status s_ = (call);                                                           \
    checks++;                                                                        \
    if (s_ != (kc_status)(want)) {                                                   \
      fprintf(stderr, "%s:%d: %s returned %u (%s), want %s\n", __FILE__, __LINE__,   \
              #call, (unsigned)s_, kc_status_message(s_), #want);                    \
      failures++;                                                                    \
    }                                                                                \
  } while (0)

#define DEG (3.14159265358979323846 / 180.0)

/* The CSV reader's checks (csv_test.c). */
void kc_csv_test(void);

#endif
