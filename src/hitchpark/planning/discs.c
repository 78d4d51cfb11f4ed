/* The planner's fast collision check, compiled: grid.Discs.least_numpy's arithmetic for each point, operation for
   operation, so that each point's numbers agree with NumPy's to the last bit (and so their least: it does not
   depend on the order the points are taken in). In NumPy it was half of a search's time among obstacles (every
   outline point of every sample of every primitive, each a few temporary arrays).

   n, k          motions and samples per motion
   states        (n, k, 4) x, y, yaw, hitch of the trailer axle at each sample
   trig          (n, k, 4) cos yaw, sin yaw, cos(yaw + hitch), sin(yaw + hitch), computed by NumPy
   half          (n, k)    half the bodies' movement into each sample [m]
   tx, ty        (nt)      the trailer's points in its frame
   vx, vy        (nv)      the vehicle's points in its frame
   lt, lh        (nv)      each vehicle point's trailer length and hitch offset
   radius        (nt + nv) each point's disc
   grid          (nx + 2, ny + 2) the distance grid in a frame of -inf, row-major
   stop          a motion's look ends once its sure value is at most this and its most value below it (its
                 answers to "clear by stop?" and "surely nearer than stop?" are then known): -inf looks at all
   ng, order     the points in groups of neighbours: group g is points order[starts[g] .. starts[g + 1]) (indices
   starts        into the trailer's then the vehicle's), all of one body (vehicle[g]), within reach[g] of a
   vehicle, cx,  centre (cx[g], cy[g]) of that body's frame (a vehicle group's with lengths glt[g], glh[g]); with a
   cy, glt, glh, finite stop, a group whose centre's grid distance shows every point of it surely clear by stop is
   reach         not looked at point by point (the grid's distance changes by at most the distance between cell
                 centres: a point's is at least the centre's less reach[g] and a cell diagonal)
   sure, most    (n)       out: the least of distance - error - radius - half, and of distance + error (of the
                           points looked at): with a finite stop, only their answers to the two questions are sure
*/
#include <math.h>

typedef long long hp_int;

/* np.minimum's choice: NaN wins. */
static double least(double a, double b) { return (a < b || a != a) ? a : b; }

/* DistanceGrid.lookup's index along one axis: the cell plus one, or 0 (the frame) off the grid (or NaN). On the
   grid the quotient is not negative, where truncation is floor, and floor(v) < count exactly when v < count. */
static hp_int cell(double p, double origin, double size, hp_int count) {
    double v = (p - origin) / size;
    return (v >= 0.0 && v < (double)count) ? (hp_int)v + 1 : 0;
}

/* Whether every point within reach of (px, py) lies on the grid (a point off it reads the frame). */
static int on_grid(double px, double py, double reach, double origin_x, double origin_y, double size, hp_int nx,
                   hp_int ny) {
    double u = (px - origin_x) / size, v = (py - origin_y) / size, r = reach / size + 1.0;
    return u - r >= 0.0 && u + r < (double)nx && v - r >= 0.0 && v + r < (double)ny;
}

int hp_disc_margins(hp_int n, hp_int k, const double *states, const double *trig, const double *half, hp_int nt,
                    const double *tx, const double *ty, hp_int nv, const double *vx, const double *vy,
                    const double *lt, const double *lh, const double *radius, const double *grid, hp_int nx,
                    hp_int ny, double origin_x, double origin_y, double size, double error, double stop, hp_int ng,
                    const hp_int *order, const hp_int *starts, const int *vehicle, const double *cx, const double *cy,
                    const double *glt, const double *glh, const double *reach, double *sure, double *most) {
    hp_int columns = ny + 2;
    int skims = isfinite(stop);
    double diagonal = size * sqrt(2.0);
    for (hp_int m = 0; m < n; m++) {
        double low = INFINITY, high = INFINITY;
        for (hp_int j = 0; j < k && !(low <= stop && high < stop); j++) {
            const double *q = states + 4 * (m * k + j), *t = trig + 4 * (m * k + j);
            double x = q[0], y = q[1], c = t[0], s = t[1], cv = t[2], sv = t[3], h = half[m * k + j];
            for (hp_int g = 0; g < ng; g++) {
                if (skims) {
                    double gx, gy;
                    if (vehicle[g]) {
                        double xr = x + glt[g] * c + glh[g] * cv, yr = y + glt[g] * s + glh[g] * sv;
                        gx = xr + cv * cx[g] - sv * cy[g];
                        gy = yr + sv * cx[g] + cv * cy[g];
                    } else {
                        gx = x + c * cx[g] - s * cy[g];
                        gy = y + s * cx[g] + c * cy[g];
                    }
                    if (on_grid(gx, gy, reach[g], origin_x, origin_y, size, nx, ny)) {
                        double d = grid[cell(gx, origin_x, size, nx) * columns + cell(gy, origin_y, size, ny)];
                        if (d - reach[g] - diagonal - 1e-9 - error - h > stop) continue; /* every point clear */
                    }
                }
                for (hp_int i = starts[g]; i < starts[g + 1]; i++) {
                    hp_int p = order[i];
                    double px, py;
                    if (p < nt) {
                        px = x + c * tx[p] - s * ty[p];
                        py = y + s * tx[p] + c * ty[p];
                    } else {
                        hp_int w = p - nt;
                        double xr = x + lt[w] * c + lh[w] * cv, yr = y + lt[w] * s + lh[w] * sv;
                        px = xr + cv * vx[w] - sv * vy[w];
                        py = yr + sv * vx[w] + cv * vy[w];
                    }
                    double d = grid[cell(px, origin_x, size, nx) * columns + cell(py, origin_y, size, ny)];
                    low = least(low, d - error - radius[p] - h);
                    high = least(high, d + error);
                }
            }
        }
        sure[m] = low;
        most[m] = high;
    }
    return 0;
}
