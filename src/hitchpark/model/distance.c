/* The exact clearance of the bodies from a scene at many configurations, compiled: what collision.SceneChecker
   asks of Shapely (GEOS), the distance between each body and each obstacle, 0 where they meet, and from the
   area's boundary, 0 where a body is not wholly inside. The same geometry in a few loops: a body has at
   most 8 corners and an obstacle a few, and Shapely's cost was in making the geometries of every sub-sample.
   Agrees with Shapely to rounding (tests/model/test_distance.py).

   m              configurations
   nb             bodies; kinds[b]: 0 a segment (2 points), 1 a polygon (its corners in order), 2 the convex
                  hull of its points; counts[b] its points (at most MAX_POINTS)
   points         (m, sum counts, 2) the bodies' points at each configuration, body after body
   no, starts     obstacles; obstacle o's vertices are vertices[starts[o] .. starts[o + 1]), a simple polygon
   boxes          (no, 4) each obstacle's xmin, ymin, xmax, ymax
   na, area       the area's boundary (na vertices, a simple polygon), na = 0: no area
   clearance      (m) out: the least distance of a body from the scene (0 where one meets it), +inf if none
*/
#include <math.h>

typedef long long hp_int;

#define MAX_POINTS 16

static double orient(const double *a, const double *b, const double *c) {
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/* Squared distance from p to the segment a-b. */
static double to_segment(const double *p, const double *a, const double *b) {
    double dx = b[0] - a[0], dy = b[1] - a[1], length = dx * dx + dy * dy;
    double t = length > 0.0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length : 0.0;
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    double ex = a[0] + t * dx - p[0], ey = a[1] + t * dy - p[1];
    return ex * ex + ey * ey;
}

/* Whether segments a-b and c-d cross at a point inside both (touching and overlapping are left to the
   distances, which are 0 there). */
static int cross(const double *a, const double *b, const double *c, const double *d) {
    double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
    return ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0)) && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0));
}

/* Whether p lies inside the polygon of n vertices (crossing number; on the boundary either answer, where the
   distance is 0 anyway). */
static int inside(const double *p, const double *polygon, hp_int n) {
    int in = 0;
    for (hp_int i = 0, j = n - 1; i < n; j = i++) {
        const double *a = polygon + 2 * j, *b = polygon + 2 * i;
        if ((a[1] > p[1]) != (b[1] > p[1]) && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]) in = !in;
    }
    return in;
}

/* The convex hull of n points (Andrew's monotone chain), counter-clockwise, into hull; returns its size. */
static hp_int convex_hull(const double *points, hp_int n, double *hull) {
    double sorted[2 * MAX_POINTS];
    for (hp_int i = 0; i < n; i++) {  /* insertion sort by x, then y */
        double x = points[2 * i], y = points[2 * i + 1];
        hp_int j = i;
        while (j > 0 && (sorted[2 * j - 2] > x || (sorted[2 * j - 2] == x && sorted[2 * j - 1] > y))) {
            sorted[2 * j] = sorted[2 * j - 2];
            sorted[2 * j + 1] = sorted[2 * j - 1];
            j--;
        }
        sorted[2 * j] = x;
        sorted[2 * j + 1] = y;
    }
    hp_int h = 0;
    for (hp_int k = 0; k < n; k++) { /* the lower chain */
        const double *p = sorted + 2 * k;
        while (h >= 2 && orient(hull + 2 * (h - 2), hull + 2 * (h - 1), p) <= 0.0) h--;
        hull[2 * h] = p[0];
        hull[2 * h + 1] = p[1];
        h++;
    }
    for (hp_int k = n - 2, lower = h + 1; k >= 0; k--) { /* the upper chain */
        const double *p = sorted + 2 * k;
        while (h >= lower && orient(hull + 2 * (h - 2), hull + 2 * (h - 1), p) <= 0.0) h--;
        hull[2 * h] = p[0];
        hull[2 * h + 1] = p[1];
        h++;
    }
    h--; /* its last point is its first */
    return h < 1 ? 1 : h;
}

/* The edges of a body of n vertices: a closed polygon when n > 2, else one segment (or a point). */
static hp_int edge_count(hp_int n) { return n > 2 ? n : 1; }

/* Distance between a body (n vertices, see edge_count) and a simple polygon (k vertices): 0 where they meet.
   Only the ring of the polygon when ring is set (the distance to its boundary). */
static double body_distance(const double *body, hp_int n, const double *polygon, hp_int k, int ring) {
    hp_int edges = edge_count(n);
    for (hp_int i = 0; i < edges; i++) {
        const double *a = body + 2 * i, *b = body + 2 * ((i + 1) % n);
        for (hp_int j = 0, l = k - 1; j < k; l = j++)
            if (cross(a, b, polygon + 2 * l, polygon + 2 * j)) return 0.0;
    }
    if (!ring && (inside(body, polygon, k) || (n > 2 && inside(polygon, body, n)))) return 0.0;
    double least = INFINITY;
    for (hp_int i = 0; i < n; i++)
        for (hp_int j = 0, l = k - 1; j < k; l = j++) {
            double d = to_segment(body + 2 * i, polygon + 2 * l, polygon + 2 * j);
            if (d < least) least = d;
        }
    for (hp_int j = 0; j < k; j++)
        for (hp_int i = 0; i < edges; i++) {
            double d = to_segment(polygon + 2 * j, body + 2 * i, body + 2 * ((i + 1) % n));
            if (d < least) least = d;
        }
    return sqrt(least);
}

int hp_scene_clearances(hp_int m, hp_int nb, const int *kinds, const hp_int *counts, const double *points, hp_int no,
                        const hp_int *starts, const double *vertices, const double *boxes, hp_int na,
                        const double *area, double *clearance) {
    hp_int total = 0;
    for (hp_int b = 0; b < nb; b++) {
        if (counts[b] < 1 || counts[b] > MAX_POINTS) return 1;
        total += counts[b];
    }
    for (hp_int c = 0; c < m; c++) {
        double best = INFINITY;
        const double *at = points + 2 * total * c;
        for (hp_int b = 0; b < nb; b++) {
            double hull[4 * MAX_POINTS];
            const double *body = at;
            hp_int n = counts[b];
            at += 2 * n;
            if (kinds[b] == 2) {
                n = convex_hull(body, n, hull);
                body = hull;
            } else if (kinds[b] == 0) {
                n = 2;
            }
            double box[4] = {body[0], body[1], body[0], body[1]};
            for (hp_int i = 1; i < n; i++) {
                box[0] = fmin(box[0], body[2 * i]);
                box[1] = fmin(box[1], body[2 * i + 1]);
                box[2] = fmax(box[2], body[2 * i]);
                box[3] = fmax(box[3], body[2 * i + 1]);
            }
            if (na > 0) {
                double d = inside(body, area, na) ? body_distance(body, n, area, na, 1) : 0.0;
                if (d < best) best = d;
            }
            for (hp_int o = 0; o < no && best > 0.0; o++) {
                const double *ob = boxes + 4 * o;
                double gx = fmax(ob[0] - box[2], box[0] - ob[2]), gy = fmax(ob[1] - box[3], box[1] - ob[3]);
                if (hypot(fmax(gx, 0.0), fmax(gy, 0.0)) >= best) continue; /* cannot come nearer */
                double d = body_distance(body, n, vertices + 2 * starts[o], starts[o + 1] - starts[o], 0);
                if (d < best) best = d;
            }
        }
        clearance[c] = best;
    }
    return 0;
}
