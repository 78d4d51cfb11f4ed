/* The separating line between each convex body and each segment of the scene, compiled.

   The same computation as clearance.separating_lines_numpy, operation for operation and in the same
   order, so that the two agree to the last bit: each NMPC step among obstacles draws its lines from
   this, and in NumPy it was most of a tick's work (docs/performance.md).

   points   (k, c, 2)       the bodies' corners: c = 2 a segment, c > 2 a convex polygon, counter-clockwise
   ends     (k or 1, m, 2, 2) the segments, each body its own (ends_per_body) or the same for all
   free     (k or 1, m, 2)  their normals to the free side, likewise (free_per_body)
   distance (k, m), n (k, m, 2), h (k, m): out, row-major as NumPy lays them out.
*/
#include <math.h>

typedef long long hp_int;

/* np.minimum and np.maximum: NaN wins. */
static double least(double a, double b) { return (a < b || a != a) ? a : b; }
static double most(double a, double b) { return (a > b || a != a) ? a : b; }

/* The point of segment a-b nearest to p (clearance._nearest_on). */
static void nearest_on(const double *p, const double *a, const double *b, double *q) {
    double dx = b[0] - a[0], dy = b[1] - a[1];
    double norm = dx * dx + dy * dy;
    double t = ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / most(norm, 1e-300);
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);  /* np.clip */
    q[0] = a[0] + t * dx;
    q[1] = a[1] + t * dy;
}

static double cross(double ux, double uy, double vx, double vy) { return ux * vy - uy * vx; }

/* Segment a-b properly crosses edge s0-s1 (each one's ends strictly either side of the other's line); *o3: where a
   lies from the edge (> 0: left of it, the body's inner side). */
static int edge_crossing(const double *a, const double *b, const double *s0, const double *s1, double *o3) {
    double o1 = cross(b[0] - a[0], b[1] - a[1], s0[0] - a[0], s0[1] - a[1]);
    double o2 = cross(b[0] - a[0], b[1] - a[1], s1[0] - a[0], s1[1] - a[1]);
    *o3 = cross(s1[0] - s0[0], s1[1] - s0[1], a[0] - s0[0], a[1] - s0[1]);
    return o1 * o2 < 0.0 && *o3 * cross(s1[0] - s0[0], s1[1] - s0[1], b[0] - s0[0], b[1] - s0[1]) < 0.0;
}

/* np.argmin's choice: the first least, or the first NaN. */
static int better(double value, double best) { return value < best || (value != value && best == best); }

int hp_separating_lines(hp_int k, hp_int c, const double *points, hp_int m, const double *ends, int ends_per_body,
                        const double *free_normal, int free_per_body, double *distance, double *n, double *h) {
    hp_int edges = c > 2 ? c : 1;
    for (hp_int i = 0; i < k; i++) {
        const double *body = points + 2 * c * i;
        const double *own_ends = ends + (ends_per_body ? 4 * m * i : 0);
        const double *own_free = free_normal + (free_per_body ? 2 * m * i : 0);
        for (hp_int j = 0; j < m; j++) {
            const double *a = own_ends + 4 * j, *b = a + 2;
            /* Corners to the segment. */
            double d_corner = 0.0, q_best[2] = {0.0, 0.0};
            hp_int i_corner = -1;
            for (hp_int corner = 0; corner < c; corner++) {
                const double *p = body + 2 * corner;
                double q[2];
                nearest_on(p, a, b, q);
                double gap = hypot(p[0] - q[0], p[1] - q[1]);
                if (i_corner < 0 || better(gap, d_corner)) {
                    i_corner = corner, d_corner = gap, q_best[0] = q[0], q_best[1] = q[1];
                }
            }
            /* The segment's ends to the body's edges (a segment body: its one edge), edge-major. */
            double d_tip = 0.0, r_best[2] = {0.0, 0.0};
            hp_int i_tip = -1;
            int crossing = 0, inside = 1;
            for (hp_int e = 0; e < edges; e++) {
                const double *s0 = body + 2 * e, *s1 = c > 2 ? body + 2 * ((e + 1) % c) : body + 2;
                for (int t = 0; t < 2; t++) {
                    const double *tip = a + 2 * t;
                    double r[2];
                    nearest_on(tip, s0, s1, r);
                    double gap = hypot(tip[0] - r[0], tip[1] - r[1]);
                    if (i_tip < 0 || better(gap, d_tip)) {
                        i_tip = 2 * e + t, d_tip = gap, r_best[0] = r[0], r_best[1] = r[1];
                    }
                }
                /* Overlap: a proper crossing of this edge and the segment; the segment's first end inside. */
                double o3;
                if (edge_crossing(a, b, s0, s1, &o3)) crossing = 1;
                if (!(o3 > 0.0)) inside = 0;
            }
            if (c > 2 && inside) crossing = 1;
            int by_corner = d_corner <= d_tip;
            const double *tip = a + 2 * (i_tip % 2);
            double body_x = by_corner ? body[2 * i_corner] : r_best[0];
            double body_y = by_corner ? body[2 * i_corner + 1] : r_best[1];
            double scene_x = by_corner ? q_best[0] : tip[0];
            double scene_y = by_corner ? q_best[1] : tip[1];
            double dist = least(d_corner, d_tip);
            int overlap = crossing || dist < 1e-9;
            double nx, ny;
            if (overlap) {
                nx = own_free[2 * j], ny = own_free[2 * j + 1];
                dist = 0.0;
            } else {
                nx = (body_x - scene_x) / dist, ny = (body_y - scene_y) / dist;
            }
            hp_int out = i * m + j;
            distance[out] = dist;
            n[2 * out] = nx, n[2 * out + 1] = ny;
            h[out] = most(nx * a[0] + ny * a[1], nx * b[0] + ny * b[1]);
        }
    }
    return 0;
}
