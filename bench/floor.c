/* The planar C floor: the cost of the bonded-pack step written as plainly as C allows.
 *
 * Not part of siku: a probe that the benchmark compiles (bench/floor.py) to say how far the
 * engine's step is from what the same work costs in straight C on this machine. It reads the
 * geometry of a benchmark scene after its warm-up steps (written by floor.py: element
 * centres, orientations and polygons projected onto a plane, the same joints and the same
 * candidate pairs) and runs the planar version of the step on one thread:
 *
 *   1. forcing: quadratic drag of a uniform wind on every free element;
 *   2. joints: two-point edge springs (the joint's two ends, stiffness K w / 2 each, with
 *      damping), force and torque on both elements;
 *   3. collisions: every candidate pair: separating-axis test, Sutherland-Hodgman clip, area
 *      and centroid, a force K A along the centre line at the centroid. The pairs the engine
 *      clipped at its last step (it skips their test) are clipped every step without the test:
 *      the jointed neighbours of a pack overlap by micrometres, which no planar projection of
 *      the sphere keeps, so the probe does the engine's clips on the planar shapes instead of
 *      finding its own;
 *   4. integration: symplectic Euler of position, angle, velocity and spin.
 *
 * What it leaves out, so that the floor is a floor: the sphere (no tangent-plane projections
 * or rotation matrices), contact laws behind a call, per-contact output rows and their
 * per-element sums (forces are added straight into the element arrays, serially), the contact
 * normal and width of eq. 10, NaN guard, timings, Python.
 *
 * Usage: floor FILE STEPS REPEAT   prints the best and median ns per element-step, the pairs
 * that overlapped at the last step and the pairs clipped without a test.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
    int64_t n, nv, nj, np;
    double dt, kc, rhoc, wu, wv;
    double *x, *y, *th, *vx, *vy, *w, *m, *I, *area, *flags;
    int64_t *off;
    double *verts;          /* local vertices, nv x 2 */
    int64_t *ji, *jj;
    double *ei, *ej;        /* joint ends in the two local frames, nj x 4 */
    double *K, *width, *zeta;
    int64_t *pairs;         /* np x 2 */
    double *clipped;        /* np: 1 where the engine clipped the pair at its last step */
} Scene;

static void *rd(FILE *f, size_t size, size_t count) {
    void *p = malloc(size * (count ? count : 1));
    if (count && fread(p, size, count, f) != count) {
        fprintf(stderr, "floor: short read\n");
        exit(2);
    }
    return p;
}

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

#define CAP 64

/* 1 when some edge line of a (CCW) has every vertex of b on its outer side or on it */
static int lines_apart(const double *a, int na, const double *b, int nb) {
    for (int k = 0; k < na; k++) {
        int k1 = k + 1 < na ? k + 1 : 0;
        double ax = a[2 * k], ay = a[2 * k + 1];
        double ex = a[2 * k1] - ax, ey = a[2 * k1 + 1] - ay;
        int inside = 0;
        for (int v = 0; v < nb; v++)
            if (ex * (b[2 * v + 1] - ay) - ey * (b[2 * v] - ax) > 0.0) { inside = 1; break; }
        if (!inside) return 1;
    }
    return 0;
}

/* area and centroid of the overlap of two convex CCW polygons (Sutherland-Hodgman) */
static double clip(const double *p1, int n1, const double *p2, int n2, double *cx, double *cy) {
    double buf[2][CAP][2];
    int cur = 0, m = n1;
    for (int i = 0; i < n1; i++) { buf[0][i][0] = p1[2 * i]; buf[0][i][1] = p1[2 * i + 1]; }
    for (int k = 0; k < n2 && m > 0; k++) {
        int k1 = k + 1 < n2 ? k + 1 : 0;
        double ax = p2[2 * k], ay = p2[2 * k + 1];
        double ex = p2[2 * k1] - ax, ey = p2[2 * k1 + 1] - ay;
        int nxt = 1 - cur, mo = 0;
        double sx = buf[cur][m - 1][0], sy = buf[cur][m - 1][1];
        double fs = ex * (sy - ay) - ey * (sx - ax);
        for (int i = 0; i < m; i++) {
            double px = buf[cur][i][0], py = buf[cur][i][1];
            double fp = ex * (py - ay) - ey * (px - ax);
            if (fp >= 0.0) {
                if (fs < 0.0 && mo < CAP) {
                    double t = fs / (fs - fp);
                    buf[nxt][mo][0] = sx + t * (px - sx); buf[nxt][mo][1] = sy + t * (py - sy); mo++;
                }
                if (mo < CAP) { buf[nxt][mo][0] = px; buf[nxt][mo][1] = py; mo++; }
            } else if (fs >= 0.0 && mo < CAP) {
                double t = fs / (fs - fp);
                buf[nxt][mo][0] = sx + t * (px - sx); buf[nxt][mo][1] = sy + t * (py - sy); mo++;
            }
            sx = px; sy = py; fs = fp;
        }
        cur = nxt; m = mo;
    }
    if (m < 3) return 0.0;
    double x0 = buf[cur][0][0], y0 = buf[cur][0][1], a2 = 0, sx = 0, sy = 0;
    for (int i = 0; i < m; i++) {
        int j = i + 1 < m ? i + 1 : 0;
        double xi = buf[cur][i][0] - x0, yi = buf[cur][i][1] - y0;
        double xj = buf[cur][j][0] - x0, yj = buf[cur][j][1] - y0;
        double c = xi * yj - xj * yi;
        a2 += c; sx += (xi + xj) * c; sy += (yi + yj) * c;
    }
    if (a2 <= 0.0) return 0.0;
    *cx = x0 + sx / (3.0 * a2);
    *cy = y0 + sy / (3.0 * a2);
    return 0.5 * a2;
}

static void step(Scene *s, double *F, double *T, double *wv, char *on, double *cs) {
    int64_t n = s->n;
    /* world vertices of every element */
    for (int64_t i = 0; i < n; i++) {
        double c = cos(s->th[i]), sn = sin(s->th[i]);
        cs[2 * i] = c;
        cs[2 * i + 1] = sn;
        for (int64_t v = s->off[i]; v < s->off[i + 1]; v++) {
            double lx = s->verts[2 * v], ly = s->verts[2 * v + 1];
            wv[2 * v] = s->x[i] + c * lx - sn * ly;
            wv[2 * v + 1] = s->y[i] + sn * lx + c * ly;
        }
    }
    /* forcing */
    for (int64_t i = 0; i < n; i++) {
        double dx = s->wu - s->vx[i], dy = s->wv - s->vy[i];
        double k = s->rhoc * s->area[i] * sqrt(dx * dx + dy * dy);
        F[2 * i] = k * dx; F[2 * i + 1] = k * dy; T[i] = 0.0;
    }
    /* joints: two-point springs */
    for (int64_t k = 0; k < s->nj; k++) {
        int64_t i = s->ji[k], j = s->jj[k];
        double ci = cs[2 * i], si = cs[2 * i + 1], cj = cs[2 * j], sj = cs[2 * j + 1];
        double kk = 0.5 * s->K[k] * s->width[k];
        double cd = 2.0 * s->zeta[k] * sqrt(kk * (s->m[i] * s->m[j] / (s->m[i] + s->m[j])));
        for (int e = 0; e < 2; e++) {
            double ax = s->ei[4 * k + 2 * e], ay = s->ei[4 * k + 2 * e + 1];
            double bx = s->ej[4 * k + 2 * e], by = s->ej[4 * k + 2 * e + 1];
            double rix = ci * ax - si * ay, riy = si * ax + ci * ay;
            double rjx = cj * bx - sj * by, rjy = sj * bx + cj * by;
            double dx = (s->x[j] + rjx) - (s->x[i] + rix), dy = (s->y[j] + rjy) - (s->y[i] + riy);
            double dvx = (s->vx[j] - s->w[j] * rjy) - (s->vx[i] - s->w[i] * riy);
            double dvy = (s->vy[j] + s->w[j] * rjx) - (s->vy[i] + s->w[i] * rix);
            double fx = kk * dx + cd * dvx, fy = kk * dy + cd * dvy; /* on i */
            F[2 * i] += fx; F[2 * i + 1] += fy; T[i] += rix * fy - riy * fx;
            F[2 * j] -= fx; F[2 * j + 1] -= fy; T[j] -= rjx * fy - rjy * fx;
        }
    }
    /* collisions */
    for (int64_t k = 0; k < s->np; k++) {
        int64_t i = s->pairs[2 * k], j = s->pairs[2 * k + 1];
        const double *pi = wv + 2 * s->off[i], *pj = wv + 2 * s->off[j];
        int ni = (int)(s->off[i + 1] - s->off[i]), nj = (int)(s->off[j + 1] - s->off[j]);
        int was = s->clipped[k] != 0.0;
        on[k] = 0;
        if (!was && (lines_apart(pi, ni, pj, nj) || lines_apart(pj, nj, pi, ni))) continue;
        double cx, cy, a = clip(pi, ni, pj, nj, &cx, &cy);
        if (a <= 0.0) continue;
        on[k] = 1;
        double nx = s->x[j] - s->x[i], ny = s->y[j] - s->y[i];
        double d = sqrt(nx * nx + ny * ny);
        nx /= d; ny /= d;
        double f = s->kc * a;          /* on j, along n */
        double fx = f * nx, fy = f * ny;
        F[2 * j] += fx; F[2 * j + 1] += fy; T[j] += (cx - s->x[j]) * fy - (cy - s->y[j]) * fx;
        F[2 * i] -= fx; F[2 * i + 1] -= fy; T[i] -= (cx - s->x[i]) * fy - (cy - s->y[i]) * fx;
    }
    /* integration */
    for (int64_t i = 0; i < n; i++) {
        if (s->flags[i] == 0.0) {
            s->vx[i] += s->dt * F[2 * i] / s->m[i];
            s->vy[i] += s->dt * F[2 * i + 1] / s->m[i];
            s->w[i] += s->dt * T[i] / s->I[i];
        }
        if (s->flags[i] != 1.0) {
            s->x[i] += s->dt * s->vx[i];
            s->y[i] += s->dt * s->vy[i];
            s->th[i] += s->dt * s->w[i];
        }
    }
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: floor FILE STEPS REPEAT\n");
        return 2;
    }
    FILE *f = fopen(argv[1], "rb");
    if (!f) { perror(argv[1]); return 2; }
    int steps = atoi(argv[2]), repeat = atoi(argv[3]);
    Scene s;
    int64_t *hdr = rd(f, 8, 4);
    s.n = hdr[0]; s.nv = hdr[1]; s.nj = hdr[2]; s.np = hdr[3];
    double *par = rd(f, 8, 5);
    s.dt = par[0]; s.kc = par[1]; s.rhoc = par[2]; s.wu = par[3]; s.wv = par[4];
    double **cols[] = {&s.x, &s.y, &s.th, &s.vx, &s.vy, &s.w, &s.m, &s.I, &s.area, &s.flags};
    for (int c = 0; c < 10; c++) *cols[c] = rd(f, 8, s.n);
    s.off = rd(f, 8, s.n + 1);
    s.verts = rd(f, 8, 2 * s.nv);
    s.ji = rd(f, 8, s.nj); s.jj = rd(f, 8, s.nj);
    s.ei = rd(f, 8, 4 * s.nj); s.ej = rd(f, 8, 4 * s.nj);
    s.K = rd(f, 8, s.nj); s.width = rd(f, 8, s.nj); s.zeta = rd(f, 8, s.nj);
    s.pairs = rd(f, 8, 2 * s.np);
    s.clipped = rd(f, 8, s.np);
    fclose(f);
    double *F = calloc(2 * s.n, 8), *T = calloc(s.n, 8), *wv = calloc(2 * s.nv, 8);
    double *cs = calloc(2 * s.n, 8);
    char *on = calloc(s.np ? s.np : 1, 1);
    double *per = calloc(repeat, 8);
    int overl = 0, nclip = 0;
    for (int k = 0; k < 2; k++) step(&s, F, T, wv, on, cs);
    for (int r = 0; r < repeat; r++) {
        double t0 = now();
        for (int k = 0; k < steps; k++) step(&s, F, T, wv, on, cs);
        per[r] = (now() - t0) / steps / s.n * 1e9;
    }
    for (int64_t k = 0; k < s.np; k++) {
        overl += on[k];
        nclip += s.clipped[k] != 0.0;
    }
    qsort(per, repeat, 8, cmp);
    printf("%.2f %.2f %d %d\n", per[0], per[repeat / 2], overl, nclip);
    return 0;
}
