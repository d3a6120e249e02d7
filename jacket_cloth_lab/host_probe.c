/* Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
 *
 * Small loops that tell what the shared host slows (jacket_cloth_lab/host_probe.py). Each
 * returns its own time in ms. patterned: branches that only their history predicts (a fixed
 * pattern); dependent: one chain of integer operations; divisions: one chain of
 * divisions; independent: eight independent multiply-add chains. */
#include <time.h>

static double now_ms(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return 1e3 * t.tv_sec + 1e-6 * t.tv_nsec;
}

double patterned(void) {
  static unsigned char pattern[64];
  static int ready = 0;
  volatile long sink[2];
  long a = 0, b = 0;
  if (!ready) {
    unsigned r = 7;
    for (int i = 0; i < 64; i++) { r = r * 1103515245u + 12345u; pattern[i] = (r >> 16) & 1; }
    ready = 1;
  }
  double t0 = now_ms();
  for (long rep = 0; rep < 20000; rep++)
    for (int i = 0; i < 64; i++) {
      if (pattern[i]) { a++; sink[0] = a; } else { b += 3; sink[1] = b; }
    }
  return now_ms() - t0;
}

double dependent(void) {
  volatile long sink;
  long s = 0;
  double t0 = now_ms();
  for (long i = 0; i < 1280000; i++) s += i ^ (s >> 3);
  sink = s;
  return now_ms() - t0;
}

double divisions(void) {
  volatile double sink;
  double x = 1.0001;
  double t0 = now_ms();
  for (long i = 0; i < 300000; i++) x = 1.0 / (x + 1e-9);
  sink = x;
  return now_ms() - t0;
}

double independent(void) {
  volatile double sink;
  double v[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  double t0 = now_ms();
  for (long i = 0; i < 400000; i++)
    for (int k = 0; k < 8; k++) v[k] = v[k] * 0.9999999 + 1e-7;
  sink = v[0] + v[7];
  return now_ms() - t0;
}
