/* apply_compensation: the C a loader needs for a standcal compensation file (its CSV view,
 * standcal-compensation/2): read b and M, check the checksum, and turn raw accelerometer
 * outputs into calibrated specific force, f = M (raw - b).
 *
 *   apply_compensation COMPENSATION.csv [RAW_UNITS] < raw.txt > calibrated.txt
 *
 * Input: one sample per line, three numbers (x y z, in the file's raw units) separated by
 * spaces, tabs or commas; blank lines and lines starting with '#' are skipped. Output: f in
 * m/s^2, "x y z" per line. RAW_UNITS (e.g. "m/s^2", "counts"): what the input is in; a file
 * for other units is refused. Exit 0, or 2 with a message naming the file and line.
 *
 * The checksum is zlib's CRC-32 over "raw_units=UNITS\n" and the twelve numbers b_x, b_y,
 * b_z, M_11 ... M_33, each printed with "%.17g" and a newline: a double printed with 17
 * significant digits reads back as the same double, so the numbers parsed here reproduce
 * the text standcal hashed. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

struct compensation {
  char raw_units[64];
  double b[3];
  double m[3][3];
  unsigned long stated_crc;
  int have_crc;
  int rows_seen; /* bit 0: b, bits 1..3: M's rows */
};

static int fail(const char *file, long line, const char *what) {
  if (line > 0)
    fprintf(stderr, "%s:%ld: %s\n", file, line, what);
  else
    fprintf(stderr, "%s: %s\n", file, what);
  return 2;
}

/* Reads one line into `line`; 0 at the end, -1 for a line longer than the buffer. The
 * trailing newline and carriage return are removed. */
static int read_line(FILE *f, char *line, size_t size) {
  if (fgets(line, (int)size, f) == NULL) return 0;
  size_t n = strlen(line);
  if (n > 0 && line[n - 1] == '\n') {
    line[--n] = '\0';
  } else if (!feof(f)) {
    return -1;
  }
  if (n > 0 && line[n - 1] == '\r') line[--n] = '\0';
  return 1;
}

/* Three numbers after "name,": 0 when the row holds them. */
static int parse_three(const char *text, double out[3]) {
  const char *p = text;
  for (int k = 0; k < 3; ++k) {
    char *end = NULL;
    if (*p != ',') return -1;
    errno = 0;
    out[k] = strtod(p + 1, &end);
    /* ERANGE on an overflow only: a subnormal (underflow) is a value standcal may write. */
    if (end == p + 1 || (errno == ERANGE && (out[k] > 1 || out[k] < -1))) return -1;
    p = end;
  }
  return 0;
}

static int read_compensation(const char *path, struct compensation *c) {
  FILE *f = fopen(path, "r");
  if (f == NULL) return fail(path, 0, strerror(errno));
  char line[1024];
  long number = 0;
  int got;
  memset(c, 0, sizeof *c);
  while ((got = read_line(f, line, sizeof line)) != 0) {
    ++number;
    if (got < 0) {
      fclose(f);
      return fail(path, number, "line longer than 1023 characters");
    }
    if (strncmp(line, "# raw_units: ", 13) == 0) {
      const size_t n = strlen(line + 13);
      if (n == 0 || n >= sizeof c->raw_units) {
        fclose(f);
        return fail(path, number, "raw_units: empty or longer than 63 characters");
      }
      memcpy(c->raw_units, line + 13, n + 1);
      continue;
    }
    if (strncmp(line, "# checksum_crc32: ", 18) == 0) {
      c->stated_crc = strtoul(line + 18, NULL, 16);
      c->have_crc = 1;
      continue;
    }
    if (line[0] == '#' || strncmp(line, "name,", 5) == 0) continue;
    int row = -1;
    const char *rest = NULL;
    if (strncmp(line, "b,", 2) == 0) {
      row = 0;
      rest = line + 1;
    } else if (strncmp(line, "M_row", 5) == 0 && line[5] >= '1' && line[5] <= '3' &&
               line[6] == ',') {
      row = line[5] - '0';
      rest = line + 6;
    }
    if (row < 0) continue;
    double v[3];
    if (parse_three(rest, v) != 0) {
      fclose(f);
      return fail(path, number, "expected three numbers after the row's name");
    }
    memcpy(row == 0 ? c->b : c->m[row - 1], v, sizeof v);
    c->rows_seen |= 1 << row;
  }
  const int read_error = ferror(f);
  fclose(f);
  if (read_error) return fail(path, 0, "read error");
  if (c->raw_units[0] == '\0') return fail(path, 0, "no '# raw_units:' line");
  if (c->rows_seen != 0xF)
    return fail(path, 0, "missing one of the rows b, M_row1, M_row2, M_row3");
  if (!c->have_crc) return fail(path, 0, "no '# checksum_crc32:' line");
  return 0;
}

static unsigned long checksum(const struct compensation *c) {
  char text[96 + 12 * 32];
  size_t used = (size_t)snprintf(text, sizeof text, "raw_units=%s\n", c->raw_units);
  const double *values[12] = {&c->b[0], &c->b[1], &c->b[2]};
  for (int i = 0; i < 9; ++i) values[3 + i] = &c->m[i / 3][i % 3];
  for (int i = 0; i < 12; ++i)
    used += (size_t)snprintf(text + used, sizeof text - used, "%.17g\n", *values[i]);
  return crc32(crc32(0L, Z_NULL, 0), (const Bytef *)text, (uInt)used);
}

int main(int argc, char **argv) {
  if (argc != 2 && argc != 3) {
    fprintf(stderr, "usage: %s COMPENSATION.csv [RAW_UNITS] < raw.txt > calibrated.txt\n", argv[0]);
    return 2;
  }
  struct compensation c;
  if (read_compensation(argv[1], &c) != 0) return 2;
  if (checksum(&c) != c.stated_crc) {
    char what[160];
    snprintf(what, sizeof what,
             "checksum %08lx does not match the numbers (%08lx): damaged or edited, not loaded",
             c.stated_crc, checksum(&c));
    return fail(argv[1], 0, what);
  }
  if (argc == 3 && strcmp(argv[2], c.raw_units) != 0) {
    char what[200];
    snprintf(what, sizeof what, "is for raw outputs in %s, not %s: not loaded", c.raw_units,
             argv[2]);
    return fail(argv[1], 0, what);
  }
  char line[1024];
  long number = 0;
  int got;
  while ((got = read_line(stdin, line, sizeof line)) != 0) {
    ++number;
    if (got < 0) return fail("stdin", number, "line longer than 1023 characters");
    for (char *p = line; *p != '\0'; ++p)
      if (*p == ',' || *p == '\t') *p = ' ';
    double raw[3];
    char extra;
    const char *first = line + strspn(line, " ");
    if (*first == '#' || *first == '\0') continue;
    if (sscanf(line, "%lf %lf %lf %c", &raw[0], &raw[1], &raw[2], &extra) != 3)
      return fail("stdin", number, "expected three numbers (x y z)");
    double f[3];
    for (int i = 0; i < 3; ++i)
      f[i] = c.m[i][0] * (raw[0] - c.b[0]) + c.m[i][1] * (raw[1] - c.b[1]) +
             c.m[i][2] * (raw[2] - c.b[2]);
    if (printf("%.9f %.9f %.9f\n", f[0], f[1], f[2]) < 0) return fail("stdout", 0, strerror(errno));
  }
  if (ferror(stdin)) return fail("stdin", number, "read error");
  if (fflush(stdout) != 0 || ferror(stdout)) return fail("stdout", 0, strerror(errno));
  return 0;
}
