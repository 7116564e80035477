/*
 * spectrum.h: spectra reduced to linear sRGB the way Mitsuba 3's RGB
 * variants reduce them when they load a scene.
 *
 * A spectrum (a piecewise-linear list of wavelength:value pairs, or
 * Planck's law) is integrated against the CIE 1931 2-degree colour
 * matching functions at 1000 evenly spaced wavelengths over 360..830 nm,
 * the XYZ result is scaled so that a unit spectrum has luminance Y = 1,
 * and converted to linear sRGB (Rec. 709 primaries, D65 white).  A
 * reflectance is weighted by the D65 illuminant on the way (so that a flat
 * reflectance stays grey, as an RGB renderer's white light is D65); an
 * emitter's spectrum is not, so a flat emitted spectrum comes out slightly
 * reddish, as it does in Mitsuba.  Outside the listed wavelengths the
 * spectrum is zero.
 */
#ifndef PM_SPECTRUM_H
#define PM_SPECTRUM_H

#include <stdbool.h>
#include <stddef.h>

#include "vec.h"

#define PM_CIE_MIN	360.0
#define PM_CIE_MAX	830.0
#define PM_CIE_SAMPLES	95		/* every 5 nm */

/* The CIE 1931 2-degree observer (x, y, z) at wavelength nm, linearly
 * interpolated between the 5 nm table entries; zero outside 360..830. */
void pm_cie1931_xyz(double nm, double xyz[3]);
/* The CIE D65 illuminant at nm, scaled (as Mitsuba scales it) so that
 * its integral against y is about the integral of y itself. */
double pm_cie_d65(double nm);
/* Planck's law: a black body's spectral radiance at temperature kelvin,
 * in W / (m^2 sr nm), Mitsuba's unit for the blackbody spectrum. */
double pm_blackbody(double nm, double kelvin);

/* Linear sRGB of CIE XYZ tristimulus values (Mitsuba's matrix). */
struct pm_rgb pm_xyz_to_srgb(const double xyz[3]);

/*
 * Linear sRGB of the piecewise-linear spectrum (wl[i], v[i]), i < n,
 * n >= 2, wl strictly increasing, weighted by D65 when d65.  Negative
 * components are clamped to zero, and with bounded components above one
 * to one; *clamped (if not NULL) says whether anything was.
 */
struct pm_rgb pm_spectrum_to_srgb(const double *wl, const double *v, size_t n,
    bool d65, bool bounded, bool *clamped);

/* The same for a black body of the given temperature, zero outside
 * [wmin, wmax] nm; never weighted by D65 (it is an emitter), unbounded. */
struct pm_rgb pm_blackbody_to_srgb(double kelvin, double wmin, double wmax);

#endif
