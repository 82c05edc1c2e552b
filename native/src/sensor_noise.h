/* sensor_noise.h -- the sensors' error magnitudes by index: the sensors FMU's noise.* parameters
 * (docs/sensors.md), shared by the sensor models (sensors.h), which draw them, and the estimator's
 * noise profile (noise_profile.h), which describes them to the estimator. */
#ifndef SR_SENSOR_NOISE_H
#define SR_SENSOR_NOISE_H

/* the noise.* magnitudes (FMU parameters noise.<name>, spacerobot.interface.NOISE_PARAMETERS
 * without noise.scale, in that order); units as there */
enum {
    SR_NOISE_GYRO_ARW = 0,      /* gyro white rate noise over 1 s [rad/s] */
    SR_NOISE_GYRO_BIAS,         /* gyro initial bias sd [rad/s] */
    SR_NOISE_GYRO_RRW,          /* gyro bias change over 1 s [rad/s] */
    SR_NOISE_STAR_CROSS,        /* star tracker about base x, y [rad] */
    SR_NOISE_STAR_ROLL,         /* star tracker about base z [rad] */
    SR_NOISE_NAV_R,             /* navigation position [m] */
    SR_NOISE_NAV_V,             /* navigation velocity [m/s] */
    SR_NOISE_ACCEL_VRW,         /* accelerometer white noise over 1 s [m/s2] */
    SR_NOISE_ACCEL_BIAS,        /* accelerometer initial bias sd [m/s2] */
    SR_NOISE_ACCEL_BRW,         /* accelerometer bias change over 1 s [m/s2] */
    SR_NOISE_ALPHA,             /* angular acceleration [rad/s2] */
    SR_NOISE_ENC_RESOLUTION,    /* encoder quantisation step [rad] (0: none) */
    SR_NOISE_ENC_Q,             /* joint angle noise before quantisation [rad] */
    SR_NOISE_ENC_QD,            /* joint rate noise [rad/s] */
    SR_NOISE_ENC_QDD,           /* joint acceleration noise [rad/s2] */
    SR_NOISE_THRUST_SCALE,      /* thrust scale factor error sd [1] */
    SR_NOISE_THRUST_MISALIGN,   /* thrust misalignment sd per axis [rad] */
    SR_NOISE_COUNT
};


/* noise.scale, the factor of every magnitude, is at most this (a million times the magnitudes as
   set) */
#define SR_NOISE_SCALE_MAX 1e6

/* The FMU parameter name of magnitude i ("noise.gyro.arw", ...), NULL for i out of
   0..SR_NOISE_COUNT-1. */
const char *sr_noise_name(int i);

#endif
