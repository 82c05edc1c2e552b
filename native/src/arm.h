/* The robot record: the whole free-floating robot (base body, the serial arm of revolute joints,
 * the end-effector frame E) as plain data, and its reader.
 *
 * The record is a small versioned text file (written by spacerobot/core/robot_record.py) that
 * the FMUs carry in resources/: one FMU binary then serves every robot. Every double is stored
 * as its IEEE-754 bit pattern in hex (0x4036b33333333333), so reading it is exact and needs no
 * locale-dependent C library call; the decimal value follows in a comment for people.
 *
 * Format (version 1): one `key value...` per line; '#' starts a comment; blank lines are
 * ignored; the keys may come in any order, each exactly once, and the record ends with `end`:
 *
 *   spacerobot-robot 1                first line (an UTF-8 byte order mark before it is skipped)
 *   name NAME                         1..63 printable ASCII characters, no blank, no '#'
 *   planar 0|1                        motion in the base x-y plane (rotation about z)
 *   n N                               number of movable joints, 1..SR_MAX_JOINTS
 *   base.mass M  base.com X Y Z  base.inertia I11 I12 ... I33     (the base body, frame B)
 *   linkK.joint NAME                  K = 1..n: the joint that moves link K (name as above)
 *   linkK.xyz X Y Z                   joint frame origin in the parent frame [m]
 *   linkK.R R11 R12 ... R33           joint frame orientation in the parent frame, row-major
 *   linkK.axis X Y Z                  unit joint axis in the joint frame
 *   linkK.mass M  linkK.com X Y Z  linkK.inertia I11 ... I33           (link K, its frame)
 *   ee.xyz X Y Z  ee.R R11 ... R33    end-effector frame E in the last link's frame
 *   end
 *
 * The parent of link 1 is the base frame B (origin at the base sensor point S); of link K > 1,
 * link K-1. Bodies: mass [kg] > 0, centre of mass [m] and inertia about it [kg.m2] (symmetric,
 * positive definite, principal moments obeying the triangle inequality) in the body's frame.
 */
#ifndef SR_ARM_H
#define SR_ARM_H

#include <stddef.h>

#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most movable joints a robot may have. */
#define SR_MAX_JOINTS 12
/** Longest robot or joint name, in bytes, without the terminating NUL. */
#define SR_NAME_MAX 63
/** The record format version this reader reads. */
#define SR_ROBOT_RECORD_VERSION 1

/** One rigid body: mass [kg], centre of mass com [m] and inertia about the com I (3 x 3,
 *  row-major) [kg.m2], both in the body's own frame. */
typedef struct sr_body {
    double m, com[3], I[9];
} sr_body;

/** The whole robot (a plain struct: no pointers, copy it freely). Arrays past n are zero. */
typedef struct sr_robot {
    char name[SR_NAME_MAX + 1];          /* NUL-terminated */
    int planar;                          /* 1: motion in the base x-y plane */
    int n;                               /* movable joints, 1..SR_MAX_JOINTS */
    sr_body base;                        /* base body, frame B (origin at the sensor point S) */
    double xyz[SR_MAX_JOINTS][3];        /* joint i origin in the parent frame [m] */
    double R[SR_MAX_JOINTS][9];          /* joint i frame in the parent frame (3 x 3) at q = 0 */
    double axis[SR_MAX_JOINTS][3];       /* unit joint axis, joint frame */
    sr_body link[SR_MAX_JOINTS];         /* link i moved by joint i, in the joint frame */
    double ee_xyz[3], ee_R[9];           /* end-effector frame E in the last link's frame */
    char joint[SR_MAX_JOINTS][SR_NAME_MAX + 1];   /* joint names (NUL-terminated) */
} sr_robot;

/** Parse a record from text (len bytes, need not be NUL-terminated; never read past len).
 *  Returns 0 and fills *out, or nonzero with *out zeroed and a one-line message in err
 *  (errlen bytes, always NUL-terminated when errlen > 0; err may be NULL) naming the line and
 *  what is wrong: wrong version, missing, unknown or repeated key, n out of range, a malformed
 *  number, a non-finite or non-physical value, an axis not of unit length, R not a rotation. */
SR_API int sr_robot_parse(const char *text, size_t len, sr_robot *out, char *err, size_t errlen);

/** Read and parse the record file at path (opened "rb", at most 16 MiB): as sr_robot_parse,
 *  plus "cannot open" / "cannot read" / "too large" errors. */
SR_API int sr_robot_read(const char *path, sr_robot *out, char *err, size_t errlen);

/** sizeof(sr_robot), so that a binding can check its view of the struct. */
SR_API size_t sr_robot_size(void);

#ifdef __cplusplus
}
#endif

#endif /* SR_ARM_H */
