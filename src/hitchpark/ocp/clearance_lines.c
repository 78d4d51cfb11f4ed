/* The obstacle OCP's parameters of one NMPC step, compiled: each body's separating lines at each prediction step.

   The same computation as hitchpark.ocp.obstacles.ClearanceConstraints.parameters (with its lines), operation
   for operation and in the same order, so that the two agree to the last bit: the in-process controller calls
   this where it compiles, and hitchpark export's package carries it (hitchpark_nmpc.c among obstacles).
   It works a body and a step at a time, so it needs no memory but the caller's `scratch`.

   states   (N + 1) rows of `stride` numbers: x, y, yaw, hitch of X_0..X_N in the parking frame
   shape    the vehicle's lengths: L_T, L_H, rear overhang, wheelbase + front overhang, vehicle width / 2,
            trailer rear, trailer front, trailer width / 2, and 1 if the tow bar sticks out behind the body
   pieces   the scene's convex pieces in the parking frame, padded to `size` vertices each: vertices (j, size, 2),
            edges (j, size, 2, 2) (vertex i to i + 1, the last to the first), outward normals (j, size, 2) (0 where
            the edge is not real), real (j, size) 1 or 0
   out      (N, bodies, planes, 3): per step, body and line, (n_x, n_y, h + c); (0, 0, -1) unused
   scratch  at least (6 + size) * j doubles
*/
#include "separating_lines.c"

#define HP_REACH 2.5 /* obstacles.REACH_M */

typedef struct {
    hp_int n, size;
    const double *vertices, *edges, *outward, *real;
    const double *extent; /* (n, size): each edge's outward normal's largest product with the piece's vertices */
} hp_pieces;

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

/* ClearanceConstraints.lines for one body (its 4 points) and one piece: distance, normal n and offset h.
   anchor: the body where the car is now (NULL: none). */
static void hp_line(const double *points, const double *anchor, const hp_pieces *pc, hp_int j, double *distance,
                    double *n, double *h) {
    hp_int size = pc->size;
    const double *vert = pc->vertices + 2 * size * j, *out = pc->outward + 2 * size * j, *real = pc->real + size * j;
    double low[2], high[2], vmin[2], vmax[2], apart[2];
    double best = INFINITY, nearest[2] = {0.0, 0.0};
    hp_int i_best = -1;
    for (int x = 0; x < 2; x++) {
        low[x] = high[x] = points[x];
        for (int c = 1; c < 4; c++) low[x] = least(low[x], points[2 * c + x]), high[x] = most(high[x], points[2 * c + x]);
        vmin[x] = vmax[x] = vert[x];
        for (hp_int v = 1; v < size; v++) vmin[x] = least(vmin[x], vert[2 * v + x]), vmax[x] = most(vmax[x], vert[2 * v + x]);
        apart[x] = most(most(vmin[x] - high[x], low[x] - vmax[x]), 0.0);
    }
    /* The nearest edge, of the real ones (the pieces within reach only: the others keep distance inf). */
    if (hypot(apart[0], apart[1]) <= HP_REACH) {
        for (hp_int v = 0; v < size; v++) {
            double gap, normal[2], unused;
            /* An edge that is not real (a padded piece's repeats) has gap inf, which never wins: not drawn. Edge 0
               is always real, so the first taken is. */
            if (real[v] == 0.0) continue;
            hp_separating_lines(1, 4, points, 1, pc->edges + 4 * (size * j + v), 0, out + 2 * v, 0, &gap, normal, &unused);
            if (i_best < 0 || better(gap, best)) i_best = v, best = gap, nearest[0] = normal[0], nearest[1] = normal[1];
        }
    } else {
        for (hp_int v = 0; v < size; v++)
            if (i_best < 0) i_best = v; /* every gap inf: np.argmin's first */
    }
    {
        /* A body wholly inside the piece: its first corner left of every real edge. */
        int inside = 1, overlap;
        double dist = best, near_score, h_near = -INFINITY, edge_score = -INFINITY, reach_v;
        hp_int edge = -1;
        for (hp_int v = 0; v < size; v++) {
            double side = (points[0] - vert[2 * v]) * out[2 * v] + (points[1] - vert[2 * v + 1]) * out[2 * v + 1];
            if (!(side < 0.0 || real[v] == 0.0)) inside = 0;
        }
        overlap = inside || dist <= 1e-9;
        if (overlap) dist = 0.0;
        for (hp_int v = 0; v < size; v++) h_near = v == 0 ? dot(nearest, vert) : most(h_near, dot(nearest, vert + 2 * v));
        near_score = dist;
        if (anchor) {
            double a = dot(anchor, nearest);
            for (int c = 1; c < 4; c++) a = least(a, dot(anchor + 2 * c, nearest));
            near_score = least(near_score, a - h_near);
        }
        /* The edge whose line leaves the widest gap to the body (here, and where the car is now). */
        for (hp_int v = 0; v < size; v++) {
            double extent = pc->extent[size * j + v], margin;
            reach_v = dot(points, out + 2 * v);
            for (int c = 1; c < 4; c++) reach_v = least(reach_v, dot(points + 2 * c, out + 2 * v));
            if (anchor) {
                double a = dot(anchor, out + 2 * v);
                for (int c = 1; c < 4; c++) a = least(a, dot(anchor + 2 * c, out + 2 * v));
                reach_v = least(reach_v, a);
            }
            margin = real[v] != 0.0 ? reach_v - extent : -INFINITY;
            /* np.argmax: the first greatest, or the first NaN */
            if (edge < 0 || margin > edge_score || (margin != margin && edge_score == edge_score))
                edge = v, edge_score = margin;
        }
        if (overlap || edge_score >= near_score) n[0] = out[2 * edge], n[1] = out[2 * edge + 1];
        else n[0] = nearest[0], n[1] = nearest[1];
        *h = dot(n, vert);
        for (hp_int v = 1; v < size; v++) *h = most(*h, dot(n, vert + 2 * v));
        *distance = dist;
    }
}

/* np.argsort's order (stable): a before b where a is greater, NaN after every number. */
static int after(double a, double b) { return a > b || (a != a && b == b); }

int hp_clearance_lines(hp_int n_steps, const double *states, hp_int stride, const double *shape, hp_int n_pieces,
                       hp_int size, const double *vertices, const double *edges, const double *outward,
                       const double *real, hp_int planes, double clearance, int anchored, int keep_warm,
                       double *scratch, double *out) {
    hp_pieces pc = {n_pieces, size, vertices, edges, outward, real, scratch + 6 * n_pieces};
    double *extent = scratch + 6 * n_pieces;
    double quads[4 * 8], low[2] = {0.0, 0.0}, high[2] = {0.0, 0.0};
    hp_int n_bodies = shape[8] != 0.0 ? 4 : 3, within = 0;
    double *dist = scratch, *nx = scratch + n_pieces, *ny = scratch + 2 * n_pieces, *hh = scratch + 3 * n_pieces;
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
            }
    }
    for (int x = 0; x < 2; x++) low[x] = low[x] - HP_REACH, high[x] = high[x] + HP_REACH;
    for (hp_int j = 0; j < n_pieces; j++) {
        const double *vert = vertices + 2 * size * j;
        int meets = 1;
        for (int x = 0; x < 2; x++) {
            double lo = vert[x], hi = vert[x];
            for (hp_int v = 1; v < size; v++) lo = least(lo, vert[2 * v + x]), hi = most(hi, vert[2 * v + x]);
            if (!(hi >= low[x] && lo <= high[x])) meets = 0;
        }
        if (meets) piece[within++] = j;
    }
    if (within == 0) return 0;
    for (hp_int i = 0; i < within; i++) { /* np.einsum("jvx,jwx->jvw", outward, vertices).max(axis=2) */
        hp_int j = piece[i];
        const double *vert = vertices + 2 * size * j, *out_j = outward + 2 * size * j;
        for (hp_int v = 0; v < size; v++) {
            double e = dot(out_j + 2 * v, vert);
            for (hp_int w = 1; w < size; w++) e = most(e, dot(out_j + 2 * v, vert + 2 * w));
            extent[size * j + v] = e;
        }
    }
    {
        double anchor[4 * 8], here[4 * 8];
        hp_int take = planes < within ? planes : within;
        hp_bodies(states, shape, anchor);
        for (hp_int k = 0; k < n_steps; k++) {
            hp_bodies(states + stride * (k + 1), shape, here);
            for (hp_int b = 0; b < n_bodies; b++) {
                const double *points = here + 8 * b;
                for (hp_int i = 0; i < within; i++) {
                    double n2[2];
                    hp_line(points, anchored ? anchor + 8 * b : 0, &pc, piece[i], dist + i, n2, hh + i);
                    nx[i] = n2[0], ny[i] = n2[1];
                }
                /* keep_warm: an anchored line that cuts the warm start's body where it keeps the clearance takes
                   the body's own line at this step instead. */
                if (anchored && keep_warm) {
                    for (hp_int i = 0; i < within; i++) {
                        double n2[2] = {nx[i], ny[i]}, slack = dot(points, n2);
                        for (int c = 1; c < 4; c++) slack = least(slack, dot(points + 2 * c, n2));
                        slack = slack - hh[i] - clearance;
                        if (slack < 0.0 && dist[i] >= clearance && isfinite(dist[i])) {
                            double own_d, own_n[2], own_h;
                            hp_line(points, 0, &pc, piece[i], &own_d, own_n, &own_h);
                            nx[i] = own_n[0], ny[i] = own_n[1], hh[i] = own_h;
                        }
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
                    double *slot = out + 3 * ((k * n_bodies + b) * planes + t);
                    if (dist[i] <= HP_REACH) slot[0] = nx[i], slot[1] = ny[i], slot[2] = hh[i] + clearance;
                }
            }
        }
    }
    return 0;
}
