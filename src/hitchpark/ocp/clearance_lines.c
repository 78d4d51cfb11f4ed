/* The obstacle OCP's parameters of one NMPC step, compiled: each body's separating lines at each prediction step.

   The same computation as hitchpark.ocp.obstacles.ClearanceConstraints.parameters (with its lines), operation
   for operation and in the same order for every number that reaches the answer, so that the two agree to the
   last bit for finite states (the work whose numbers do not is left out: see clearance_pieces.c, which this includes; a state that is
   not finite, which no caller draws lines for, may give other lines): the in-process controller calls
   this where it compiles, and hitchpark export's package carries it (hitchpark_nmpc.c among obstacles).
   It works a body and a step at a time, so it needs no memory but the caller's `scratch`.

   states   (N + 1) rows of `stride` numbers: x, y, yaw, hitch of X_0..X_N in the parking frame
   shape    the vehicle's lengths: L_T, L_H, rear overhang, wheelbase + front overhang, vehicle width / 2,
            trailer rear, trailer front, trailer width / 2, and 1 if the tow bar sticks out behind the body
   pieces   the scene's convex pieces in the parking frame, padded to `size` vertices each: vertices (j, size, 2),
            edges (j, size, 2, 2) (vertex i to i + 1, the last to the first), outward normals (j, size, 2) (0 where
            the edge is not real), real (j, size) 1 or 0
   out      (N, bodies, planes, 3): per step, body and line, (n_x, n_y, h + c); (0, 0, -1) unused
   scratch  at least (11 + size) * j doubles
*/
#include <string.h>
#include "separating_lines.c"

#define HP_REACH 2.5 /* obstacles.REACH_M */
#define HP_MAX_SIZE 64 /* the most vertices a piece is padded to that hp_nearest sorts the edges of */

typedef struct {
    hp_int n, size;
    const double *vertices, *edges, *outward, *real;
    const double *extent; /* (n, size): each edge's outward normal's largest product with the piece's vertices */
    const double *box;    /* (n, 4): each piece's least x, y and greatest x, y */
    const hp_int *distinct; /* (n): each piece's vertices up to its last distinct one (the padding repeats it) */
} hp_pieces;

/* The vertices of a piece padded to `size` with its last (obstacles._padded) up to the last that differs from the
   one before it, bit for bit: a greatest product over the vertices may stop there (most of a number it already took
   is that number, bit for bit). The edges may not (the last, back to the first, is real). */
static hp_int hp_distinct(const double *vert, hp_int size) {
    hp_int count = size;
    while (count > 1 && memcmp(vert + 2 * (count - 1), vert + 2 * (count - 2), 2 * sizeof(double)) == 0) count--;
    return count;
}

/* body_corners at one configuration: the bodies as quads (a segment a-b as a, b, b, a), (bodies, 4, 2). */
static hp_int hp_bodies(const double *x4, const double *shape, double *quads) {
    double x = x4[0], y = x4[1], yaw = x4[2], hitch = x4[3];
    double L_T = shape[0], L_H = shape[1];
    double c_t = cos(yaw), s_t = sin(yaw);
    double x_h = x + L_T * c_t, y_h = y + L_T * s_t; /* Eqs. (25)-(26) */
    double yaw_v = yaw + hitch;
    double x_r = x_h + L_H * cos(yaw_v), y_r = y_h + L_H * sin(yaw_v); /* Eqs. (27)-(28) */
    const double box[2][6] = {{x_r, y_r, yaw_v, shape[2], shape[3], shape[4]}, {x, y, yaw, shape[5], shape[6], shape[7]}};
    for (int b = 0; b < 2; b++) {
        double c = cos(box[b][2]), s = sin(box[b][2]);
        double back = box[b][3], front = box[b][4], half = box[b][5];
        const double local[4][2] = {{-back, -half}, {front, -half}, {front, half}, {-back, half}};
        for (int i = 0; i < 4; i++) {
            double a = local[i][0], e = local[i][1];
            quads[8 * b + 2 * i] = box[b][0] + a * c - e * s;
            quads[8 * b + 2 * i + 1] = box[b][1] + a * s + e * c;
        }
    }
    {
        double seg[2][4] = {{x + shape[6] * c_t, y + shape[6] * s_t, x_h, y_h}, {0.0, 0.0, x_h, y_h}};
        hp_int n = shape[8] != 0.0 ? 4 : 3;
        seg[1][0] = x_r - shape[2] * cos(yaw_v);
        seg[1][1] = y_r - shape[2] * sin(yaw_v);
        for (hp_int b = 2; b < n; b++) {
            const double *p = seg[b - 2];
            double *q = quads + 8 * b;
            q[0] = p[0], q[1] = p[1], q[2] = p[2], q[3] = p[3], q[4] = p[2], q[5] = p[3], q[6] = p[0], q[7] = p[1];
        }
        return n;
    }
}

/* p . v of two xy pairs (np.einsum over x, np.sum over the last axis). */
static double dot(const double *p, const double *v) { return p[0] * v[0] + p[1] * v[1]; }

#include "clearance_pieces.c"

/* np.argsort's order (stable): a before b where a is greater, NaN after every number. */
static int after(double a, double b) { return a > b || (a != a && b == b); }

#define HP_TOP 16 /* the nearest distances kept to leave out pieces by (planes more: every piece is measured) */

int hp_clearance_lines(hp_int n_steps, const double *states, hp_int stride, const double *shape, hp_int n_pieces,
                       hp_int size, const double *vertices, const double *edges, const double *outward,
                       const double *real, hp_int planes, double clearance, int anchored, int keep_warm,
                       double *scratch, double *out) {
    double *extent = scratch + 6 * n_pieces, *box = scratch + (6 + size) * n_pieces;
    hp_int *distinct = (hp_int *) (scratch + (10 + size) * n_pieces);
    hp_pieces pc = {n_pieces, size, vertices, edges, outward, real, extent, box, distinct};
    double quads[4 * 8], low[2] = {0.0, 0.0}, high[2] = {0.0, 0.0}, largest = 0.0, margin;
    hp_int n_bodies = shape[8] != 0.0 ? 4 : 3, within = 0;
    double *dist = scratch, *nx = scratch + n_pieces, *ny = scratch + 2 * n_pieces, *lb = scratch + 3 * n_pieces;
    hp_int *order = (hp_int *) (scratch + 4 * n_pieces), *piece = (hp_int *) (scratch + 5 * n_pieces);
    for (hp_int i = 0; i < n_steps * n_bodies * planes; i++)
        out[3 * i] = 0.0, out[3 * i + 1] = 0.0, out[3 * i + 2] = -1.0;
    if (n_pieces == 0 || n_steps == 0) return 0;
    /* The box around every body at every step, REACH_M more each way; the pieces whose boxes meet it. */
    for (hp_int k = 0; k <= n_steps; k++) {
        hp_bodies(states + stride * k, shape, quads);
        for (hp_int i = 0; i < 4 * n_bodies; i++)
            for (int x = 0; x < 2; x++) {
                double v = quads[2 * i + x];
                if (k == 0 && i == 0) low[x] = high[x] = v;
                else low[x] = least(low[x], v), high[x] = most(high[x], v);
                largest = most(largest, fabs(v));
            }
    }
    for (int x = 0; x < 2; x++) low[x] = low[x] - HP_REACH, high[x] = high[x] + HP_REACH;
    for (hp_int j = 0; j < n_pieces; j++) {
        const double *vert = vertices + 2 * size * j;
        double *lo = box + 4 * j, *hi = lo + 2;
        int meets = 1;
        distinct[j] = hp_distinct(vert, size);
        for (int x = 0; x < 2; x++) {
            lo[x] = hi[x] = vert[x];
            for (hp_int v = 1; v < distinct[j]; v++)
                lo[x] = least(lo[x], vert[2 * v + x]), hi[x] = most(hi[x], vert[2 * v + x]);
            if (!(hi[x] >= low[x] && lo[x] <= high[x])) meets = 0;
        }
        if (meets) piece[within++] = j;
    }
    if (within == 0) return 0;
    for (hp_int i = 0; i < within; i++) { /* np.einsum("jvx,jwx->jvw", outward, vertices).max(axis=2) */
        hp_int j = piece[i];
        const double *vert = vertices + 2 * size * j, *out_j = outward + 2 * size * j;
        for (hp_int v = 0; v < size; v++) { /* read for real edges alone */
            double e = dot(out_j + 2 * v, vert);
            if (real[size * j + v] == 0.0) continue;
            for (hp_int w = 1; w < distinct[j]; w++) e = most(e, dot(out_j + 2 * v, vert + 2 * w));
            extent[size * j + v] = e;
        }
        for (hp_int v = 0; v < 2 * size; v++) largest = most(largest, fabs(vert[v]));
        for (hp_int v = 0; v < 2 * size; v++) largest = most(largest, fabs(out_j[v]));
    }
    /* Beyond any rounding of a distance or of its bounds; NaN (nothing left out) where a number is not finite. */
    margin = isfinite(largest) && largest < 1e100 ? 1e-9 * (1.0 + largest) : NAN;
    {
        double anchor[4 * 8], here[4 * 8];
        hp_int take = planes < within ? planes : within;
        hp_bodies(states, shape, anchor);
        for (hp_int k = 0; k < n_steps; k++) {
            hp_bodies(states + stride * (k + 1), shape, here);
            for (hp_int b = 0; b < n_bodies; b++) {
                const double *points = here + 8 * b, *anchor_b = anchored ? anchor + 8 * b : 0;
                double blow[2], bhigh[2], top[HP_TOP];
                hp_int pending = 0, n_top = 0, keep = planes <= HP_TOP ? planes : 0;
                for (int x = 0; x < 2; x++) {
                    blow[x] = bhigh[x] = points[x];
                    for (int c = 1; c < 4; c++)
                        blow[x] = least(blow[x], points[2 * c + x]), bhigh[x] = most(bhigh[x], points[2 * c + x]);
                }
                /* The distances that need no edge measured; the others in the order of their bounds. */
                for (hp_int i = 0; i < within; i++) {
                    double d = hp_known(points, blow, bhigh, &pc, piece[i], margin, lb + i);
                    nx[i] = ny[i] = 0.0;
                    dist[i] = d;
                    if (d != d) {
                        hp_int at = pending++;
                        while (at > 0 && lb[order[at - 1]] > lb[i]) order[at] = order[at - 1], at--;
                        order[at] = i;
                    } else if (keep) { /* the `keep` least distances so far, ascending */
                        hp_int at = n_top < keep ? n_top++ : keep;
                        while (at > 0 && top[at - 1] > d) { if (at < keep) top[at] = top[at - 1]; at--; }
                        if (at < keep) top[at] = d;
                    }
                }
                /* Each piece measured unless `keep` nearer ones are known and its bound is past them all (the
                   1e-9 of the overlap too): it is then never among the `planes` nearest, and its line never drawn. */
                for (hp_int p = 0; p < pending; p++) {
                    hp_int i = order[p];
                    double bound = lb[i] - margin, d, near[2];
                    if (keep && n_top == keep && bound > top[keep - 1] && bound > 1e-9) {
                        for (; p < pending; p++) dist[order[p]] = INFINITY;
                        break;
                    }
                    d = hp_nearest(points, blow, bhigh, &pc, piece[i], lb[i], margin, near);
                    if (d <= 1e-9) d = 0.0; /* an overlap */
                    dist[i] = d, nx[i] = near[0], ny[i] = near[1];
                    if (keep) {
                        hp_int at = n_top < keep ? n_top++ : keep;
                        while (at > 0 && top[at - 1] > d) { if (at < keep) top[at] = top[at - 1]; at--; }
                        if (at < keep) top[at] = d;
                    }
                }
                /* The `take` nearest pieces (np.argsort, stable), each line kept where it is within reach. */
                for (hp_int i = 0; i < within; i++) {
                    hp_int at = i;
                    while (at > 0 && after(dist[order[at - 1]], dist[i])) {
                        order[at] = order[at - 1];
                        at--;
                    }
                    order[at] = i;
                }
                for (hp_int t = 0; t < take; t++) {
                    hp_int i = order[t];
                    double *slot = out + 3 * ((k * n_bodies + b) * planes + t), near[2] = {nx[i], ny[i]}, n2[2], h;
                    if (!(dist[i] <= HP_REACH)) continue;
                    hp_finish(points, anchor_b, &pc, piece[i], dist[i], near, n2, &h);
                    /* keep_warm: an anchored line that cuts the warm start's body where it keeps the clearance
                       takes the body's own line at this step instead. */
                    if (anchored && keep_warm) {
                        double slack = dot(points, n2);
                        for (int c = 1; c < 4; c++) slack = least(slack, dot(points + 2 * c, n2));
                        slack = slack - h - clearance;
                        if (slack < 0.0 && dist[i] >= clearance && isfinite(dist[i]))
                            hp_finish(points, 0, &pc, piece[i], dist[i], near, n2, &h);
                    }
                    slot[0] = n2[0], slot[1] = n2[1], slot[2] = h + clearance;
                }
            }
        }
    }
    return 0;
}
