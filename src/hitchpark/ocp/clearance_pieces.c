/* One body and one piece of the scene: clearance_lines.c's measurements, included by it after its types (hp_pieces),
   the vehicle's bodies (hp_bodies) and `dot`, with separating_lines.c's helpers (most, least, better, cross,
   nearest_on) before them. hp_known tells what needs no edge measured (out of reach, inside, an overlap) and a lower
   bound of the rest; hp_nearest measures a piece's nearest real edge (hp_gap: one edge's distance and normal);
   hp_finish draws the line. */

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
