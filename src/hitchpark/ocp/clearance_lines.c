/* The obstacle OCP's parameters of one NMPC step, compiled: each body's separating lines at each prediction step.

   The same computation as hitchpark.ocp.obstacles.ClearanceConstraints.parameters (with its lines), operation
   for operation and in the same order for every number that reaches the answer, so that the two agree to the
   last bit for finite states (the work whose numbers do not is left out: see below hp_in_reach; a state that is
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

/* From here: hp_clearance_lines draws the same lines as ClearanceConstraints.lines and .parameters, operation for
   operation where a number reaches the answer, and leaves out the work whose numbers do not: a piece out of reach,
   the distances of a body and a segment that overlap (not used), the edges and corners that cannot be nearest, and
   the pieces that cannot be among a body's `planes` nearest (their lines never drawn). Work is left out only where
   a lower bound proves it, the bound less `margin` still past the least found: margin is far more than the
   rounding of either (1e-9 of the largest coordinate), and NaN (nothing left out) where a number is not finite. */

/* hypot(x, y) <= HP_REACH, without the hypot where the answer is plain (far from the reach either way). */
static int hp_in_reach(double x, double y) {
    double m = most(x, y);
    if (m > HP_REACH * (1.0 + 1e-10)) return 0;
    if (x * x + y * y <= HP_REACH * HP_REACH * (1.0 - 1e-10)) return 1;
    return hypot(x, y) <= HP_REACH;
}

/* The overlap of hp_separating_lines (one body of 4 corners, one segment a-b): a proper crossing of an edge and the
   segment (edge_crossing's), or the segment's first end inside the body. Its distances and line are then not used.
   Each corner's side of the segment is edge_crossing's o1 of its edge and o2 of the edge before, the same number:
   worked out once; an edge whose ends are not strictly either side cannot cross, and once the first end is known to
   be outside, such an edge needs nothing more. */
static int hp_overlaps(const double *body, const double *a) {
    const double *b = a + 2;
    double side[4];
    int inside = 1;
    for (int c = 0; c < 4; c++) side[c] = cross(b[0] - a[0], b[1] - a[1], body[2 * c] - a[0], body[2 * c + 1] - a[1]);
    for (int e = 0; e < 4; e++) {
        const double *s0 = body + 2 * e, *s1 = body + 2 * ((e + 1) % 4);
        int straddles = side[e] * side[(e + 1) % 4] < 0.0;
        double o3;
        if (!straddles && !inside) continue;
        o3 = cross(s1[0] - s0[0], s1[1] - s0[1], a[0] - s0[0], a[1] - s0[1]);
        if (straddles && o3 * cross(s1[0] - s0[0], s1[1] - s0[1], b[0] - s0[0], b[1] - s0[1]) < 0.0) return 1;
        if (!(o3 > 0.0)) inside = 0;
    }
    return inside;
}

/* hypot(dx, dy) surely greater than best: its square, rounded, past best's by far more than either's rounding (1e-10
   relative; hypot is within an ulp), so that better(hypot, best) is false without the hypot. best's square a normal
   number (1e-150 < best < 1e150) so that its rounding is relative; dx's or dy's square lost to underflow only makes
   the sum smaller (measured, then); NaN: not surely, measured. */
static int hp_farther(double dx, double dy, double best) {
    return best > 1e-150 && best < 1e150 && dx * dx + dy * dy > best * best * (1.0 + 1e-10);
}

/* The least of (lo - p, p - hi) along x and y: how far p is outside the box lo-hi along one axis (a lower bound of
   its distance to anything in the box). */
static double hp_outside(const double *p, const double *lo, const double *hi) {
    return most(most(lo[0] - p[0], p[0] - hi[0]), most(lo[1] - p[1], p[1] - hi[1]));
}

/* hp_separating_lines of one body of 4 corners and one segment that hp_overlaps does not overlap: the distance
   and normal. The corners and tips whose box is farther than the nearest found are not measured, nor those whose
   box is farther than `cap` (the nearest edge of the piece found so far; inf: none): where every one is, the segment
   is surely farther than cap, and the distance is inf (not its own; the caller takes it for no edge). */
static void hp_gap(const double *body, const double *a, const double *free_normal, double margin, double cap,
                   double *distance, double *n) {
    const double *b = a + 2;
    double lo[2], hi[2];
    double d_corner = INFINITY, q_best[2] = {0.0, 0.0}, d_tip = INFINITY, r_best[2] = {0.0, 0.0};
    hp_int i_corner = -1, i_tip = -1;
    for (int x = 0; x < 2; x++) lo[x] = a[x] < b[x] ? a[x] : b[x], hi[x] = a[x] < b[x] ? b[x] : a[x];
    /* Corners to the segment. */
    for (hp_int corner = 0; corner < 4; corner++) {
        const double *p = body + 2 * corner;
        double q[2], gap, bound = hp_outside(p, lo, hi) - margin;
        if (bound > cap || (i_corner >= 0 && bound > d_corner)) continue; /* farther than the nearest */
        nearest_on(p, a, b, q);
        if (i_corner >= 0 && hp_farther(p[0] - q[0], p[1] - q[1], d_corner)) continue;
        gap = hypot(p[0] - q[0], p[1] - q[1]);
        if (i_corner < 0 || better(gap, d_corner)) i_corner = corner, d_corner = gap, q_best[0] = q[0], q_best[1] = q[1];
    }
    /* The segment's ends to the body's edges, edge-major: those farther than a corner's distance are never taken. */
    for (hp_int e = 0; e < 4; e++) {
        const double *s0 = body + 2 * e, *s1 = body + 2 * ((e + 1) % 4);
        double elo[2], ehi[2];
        for (int x = 0; x < 2; x++)
            elo[x] = s0[x] < s1[x] ? s0[x] : s1[x], ehi[x] = s0[x] < s1[x] ? s1[x] : s0[x];
        for (int t = 0; t < 2; t++) {
            const double *tip = a + 2 * t;
            double r[2], gap, bound = hp_outside(tip, elo, ehi) - margin;
            if (bound > cap || bound > d_corner || (i_tip >= 0 && bound > d_tip)) continue;
            nearest_on(tip, s0, s1, r);
            if (i_tip >= 0 && hp_farther(tip[0] - r[0], tip[1] - r[1], d_tip)) continue;
            gap = hypot(tip[0] - r[0], tip[1] - r[1]);
            if (i_tip < 0 || better(gap, d_tip)) i_tip = 2 * e + t, d_tip = gap, r_best[0] = r[0], r_best[1] = r[1];
        }
    }
    if (i_corner < 0 && i_tip < 0) { /* every corner and tip past cap */
        *distance = INFINITY;
        return;
    }
    {
        int by_corner = i_corner >= 0 && d_corner <= d_tip; /* no tip measured: d_tip inf, the corner's */
        const double *tip = by_corner || i_tip < 0 ? a : a + 2 * (i_tip % 2);
        double body_x = by_corner ? body[2 * i_corner] : r_best[0];
        double body_y = by_corner ? body[2 * i_corner + 1] : r_best[1];
        double scene_x = by_corner ? q_best[0] : tip[0];
        double scene_y = by_corner ? q_best[1] : tip[1];
        double dist = least(d_corner, d_tip);
        if (dist < 1e-9) {
            n[0] = free_normal[0], n[1] = free_normal[1];
            dist = 0.0;
        } else {
            n[0] = (body_x - scene_x) / dist, n[1] = (body_y - scene_y) / dist;
        }
        *distance = dist;
    }
}

/* The first part of ClearanceConstraints.lines for one body (its 4 points, their box low-high) and one piece within
   reach that no edge overlaps: its nearest real edge's gap (the distance) and normal, the first such edge's where two
   are as near. `bound`: a lower bound of the distance to the piece. The edges are measured nearest bound first (their
   boxes' gap to the body's), so that the nearest is found early and the others, whose bound is past it, are not
   measured; an edge as near as the nearest found and before it takes its place, as the first would in edge order.
   With `margin` NaN (a number not finite), in edge order, each measured. */
static double hp_nearest(const double *points, const double *low, const double *high, const hp_pieces *pc, hp_int j,
                         double bound, double margin, double *nearest) {
    hp_int size = pc->size, order[HP_MAX_SIZE], count = 0;
    const double *out = pc->outward + 2 * size * j, *real = pc->real + size * j;
    double best = INFINITY, lbs[HP_MAX_SIZE];
    hp_int i_best = -1, sorted = margin == margin && size <= HP_MAX_SIZE;
    nearest[0] = nearest[1] = 0.0;
    for (hp_int v = 0; v < size; v++) { /* the real edges, by their bound (stable), or in order */
        const double *ends = pc->edges + 4 * (size * j + v);
        double lo[2], hi[2], lb;
        hp_int at;
        if (real[v] == 0.0) continue;
        for (int x = 0; x < 2; x++)
            lo[x] = ends[x] < ends[2 + x] ? ends[x] : ends[2 + x], hi[x] = ends[x] < ends[2 + x] ? ends[2 + x] : ends[x];
        lb = most(most(most(lo[0] - high[0], low[0] - hi[0]), most(lo[1] - high[1], low[1] - hi[1])), bound) - margin;
        if (!sorted) { /* in edge order: the bound as it was, each edge measured unless past the nearest so far */
            double gap, normal[2];
            if (i_best >= 0 && lb > best && lb >= 1e-9) continue;
            hp_gap(points, ends, out + 2 * v, margin, INFINITY, &gap, normal);
            if (i_best < 0 || better(gap, best)) i_best = v, best = gap, nearest[0] = normal[0], nearest[1] = normal[1];
            continue;
        }
        for (at = count++; at > 0 && lbs[at - 1] > lb; at--) lbs[at] = lbs[at - 1], order[at] = order[at - 1];
        lbs[at] = lb, order[at] = v;
    }
    for (hp_int i = 0; i < count; i++) {
        hp_int v = order[i];
        double gap, normal[2];
        if (i_best >= 0 && lbs[i] > best && lbs[i] >= 1e-9) break; /* this edge and every one after it */
        hp_gap(points, pc->edges + 4 * (size * j + v), out + 2 * v, margin, best, &gap, normal);
        if (i_best < 0 || gap < best || (gap == best && v < i_best))
            i_best = v, best = gap, nearest[0] = normal[0], nearest[1] = normal[1];
    }
    return best;
}

/* The rest of ClearanceConstraints.lines for one body and one piece: from its distance (0: overlap; inf: out of
   reach) and nearest normal, the line n, h. anchor: the body where the car is now (NULL: none). */
static void hp_finish(const double *points, const double *anchor, const hp_pieces *pc, hp_int j, double dist,
                      const double *nearest, double *n, double *h) {
    hp_int size = pc->size;
    const double *vert = pc->vertices + 2 * size * j, *out = pc->outward + 2 * size * j, *real = pc->real + size * j;
    int overlap = dist <= 1e-9;
    double near_score, h_near, edge_score = -INFINITY, reach_v;
    hp_int edge = -1, distinct = pc->distinct[j];
    near_score = dist;
    if (anchor) {
        h_near = dot(nearest, vert);
        for (hp_int v = 1; v < distinct; v++) h_near = most(h_near, dot(nearest, vert + 2 * v));
        double a = dot(anchor, nearest);
        for (int c = 1; c < 4; c++) a = least(a, dot(anchor + 2 * c, nearest));
        near_score = least(near_score, a - h_near);
    }
    /* The edge whose line leaves the widest gap to the body (here, and where the car is now); one that is not real
       scores -inf whatever its reach, which is then not worked out. */
    for (hp_int v = 0; v < size; v++) {
        double margin = -INFINITY;
        if (real[v] != 0.0) {
            reach_v = dot(points, out + 2 * v);
            for (int c = 1; c < 4; c++) reach_v = least(reach_v, dot(points + 2 * c, out + 2 * v));
            if (anchor) {
                double a = dot(anchor, out + 2 * v);
                for (int c = 1; c < 4; c++) a = least(a, dot(anchor + 2 * c, out + 2 * v));
                reach_v = least(reach_v, a);
            }
            margin = reach_v - pc->extent[size * j + v];
        }
        /* np.argmax: the first greatest, or the first NaN */
        if (edge < 0 || margin > edge_score || (margin != margin && edge_score == edge_score))
            edge = v, edge_score = margin;
    }
    if (overlap || edge_score >= near_score) n[0] = out[2 * edge], n[1] = out[2 * edge + 1];
    else n[0] = nearest[0], n[1] = nearest[1];
    *h = dot(n, vert);
    for (hp_int v = 1; v < distinct; v++) *h = most(*h, dot(n, vert + 2 * v));
}

/* ClearanceConstraints.lines's distance for one body and one piece where it needs no edge measured: out of reach
   (inf; 0 where the body is inside the piece), or an overlap (0). Else NAN, and *bound a lower bound of it. The
   overlap of an edge and the body is not looked for where the body's box and the piece's are apart along x or y by
   more than `margin`: neither a crossing nor an end inside the body can then be, and no rounding makes one (the
   orientations it takes are off by far less than margin). */
static double hp_known(const double *points, const double *low, const double *high, const hp_pieces *pc, hp_int j,
                       double margin, double *bound) {
    hp_int size = pc->size;
    const double *vert = pc->vertices + 2 * size * j, *out = pc->outward + 2 * size * j, *real = pc->real + size * j;
    const double *vmin = pc->box + 4 * j, *vmax = vmin + 2;
    double apart[2];
    int inside = 1;
    for (int x = 0; x < 2; x++) apart[x] = most(most(vmin[x] - high[x], low[x] - vmax[x]), 0.0);
    /* A body wholly inside the piece: its first corner left of every real edge. */
    for (hp_int v = 0; v < size && inside; v++) {
        double side = (points[0] - vert[2 * v]) * out[2 * v] + (points[1] - vert[2 * v + 1]) * out[2 * v + 1];
        if (!(side < 0.0 || real[v] == 0.0)) inside = 0;
    }
    if (!hp_in_reach(apart[0], apart[1])) return inside ? 0.0 : INFINITY;
    if (inside) return 0.0;
    if (!(most(apart[0], apart[1]) > margin))
        for (hp_int v = 0; v < size; v++)
            if (real[v] != 0.0 && hp_overlaps(points, pc->edges + 4 * (size * j + v))) return 0.0;
    /* The boxes' gap, and the gap along each edge's outward normal (the piece on its inner side, within extent). */
    *bound = most(apart[0], apart[1]);
    for (hp_int v = 0; v < size; v++) {
        double reach_v = dot(points, out + 2 * v);
        if (real[v] == 0.0) continue;
        for (int c = 1; c < 4; c++) reach_v = least(reach_v, dot(points + 2 * c, out + 2 * v));
        *bound = most(*bound, reach_v - pc->extent[size * j + v]);
    }
    return NAN;
}

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
