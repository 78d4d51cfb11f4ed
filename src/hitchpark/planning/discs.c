/* The planner's fast collision check, compiled: grid.Discs.margins_numpy, operation for operation and in the
   same order, so that the two agree to the last bit. In NumPy it was half of a search's time among
   obstacles (every outline point of every sample of every primitive, each a few temporary arrays).

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
   sure, most    (n)       out: the least of distance - error - radius - half, and of distance + error (of the
                           points looked at)
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

int hp_disc_margins(hp_int n, hp_int k, const double *states, const double *trig, const double *half, hp_int nt,
                    const double *tx, const double *ty, hp_int nv, const double *vx, const double *vy,
                    const double *lt, const double *lh, const double *radius, const double *grid, hp_int nx,
                    hp_int ny, double origin_x, double origin_y, double size, double error, double stop,
                    double *sure, double *most) {
    hp_int columns = ny + 2;
    for (hp_int m = 0; m < n; m++) {
        double low = INFINITY, high = INFINITY;
        for (hp_int j = 0; j < k && !(low <= stop && high < stop); j++) {
            const double *q = states + 4 * (m * k + j), *t = trig + 4 * (m * k + j);
            double x = q[0], y = q[1], c = t[0], s = t[1], cv = t[2], sv = t[3], h = half[m * k + j];
            for (hp_int p = 0; p < nt; p++) {
                double px = x + c * tx[p] - s * ty[p], py = y + s * tx[p] + c * ty[p];
                double d = grid[cell(px, origin_x, size, nx) * columns + cell(py, origin_y, size, ny)];
                low = least(low, d - error - radius[p] - h);
                high = least(high, d + error);
            }
            for (hp_int p = 0; p < nv; p++) {
                double xr = x + lt[p] * c + lh[p] * cv, yr = y + lt[p] * s + lh[p] * sv;
                double px = xr + cv * vx[p] - sv * vy[p], py = yr + sv * vx[p] + cv * vy[p];
                double d = grid[cell(px, origin_x, size, nx) * columns + cell(py, origin_y, size, ny)];
                low = least(low, d - error - radius[nt + p] - h);
                high = least(high, d + error);
            }
        }
        sure[m] = low;
        most[m] = high;
    }
    return 0;
}
