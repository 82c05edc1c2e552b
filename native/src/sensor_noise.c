/* sensor_noise.c -- the sensors' error magnitudes by name (sensor_noise.h). */
#include "sensor_noise.h"

static const char *const NAMES[SR_NOISE_COUNT] = {
    "noise.gyro.arw", "noise.gyro.bias", "noise.gyro.rrw", "noise.star.cross", "noise.star.roll",
    "noise.nav.r", "noise.nav.v", "noise.accel.vrw", "noise.accel.bias", "noise.accel.brw",
    "noise.alpha", "noise.enc.resolution", "noise.enc.q", "noise.enc.qd", "noise.enc.qdd",
    "noise.thrust.scale", "noise.thrust.misalign"};

const char *sr_noise_name(int i)
{
    return (i >= 0 && i < SR_NOISE_COUNT) ? NAMES[i] : 0;
}
