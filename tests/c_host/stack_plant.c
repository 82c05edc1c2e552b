/*
 * stack_plant.c -- a C host that runs the plant core (native/src/plant.h) in a thread with a
 * small stack, used by tests/test_stack_plant.py: hosts that step FMUs on worker threads give
 * them 64 KiB to 1 MiB (musl's default thread stack is 128 KiB), and the plant must run there.
 *
 * Usage: stack_plant RECORD STACK_BYTES [hog]
 *   In a thread whose stack is STACK_BYTES (pthread_attr_setstacksize): read the robot record
 *   RECORD, build the model (its own base, a 250 kg target, the propellant on, two hinged
 *   panels and two slosh modes), start, ask for
 *   the excitation at level 1 and a change of rate, then run communication steps of 0.1 s
 *   (sr_plant_advance: 100 internal RK4 steps each) through the level's ramp and the rate's
 *   change, the outputs and controls after each. Prints "ok <t> <r_S[0]>" and exits 0; on a
 *   failed call prints the status and exits 1. "hog" first uses 256 KiB of the thread's stack
 *   (the host's own check: that thread must crash when its stack is smaller).
 */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "plant.h"

typedef struct {
    const char *record;
    int hog, status;
    double t, y0;
} job;

/* touches n bytes of the stack (volatile: the compiler keeps the array and the writes) */
static double hog(size_t n)
{
    volatile char buf[1 << 18];
    size_t i;
    for (i = 0; i < n && i < sizeof buf; i += 512)
        buf[i] = (char)i;
    return (double)buf[n / 2];
}

/* two 50 kg wings (4 m x 1.6 m plates hinged at x = +-0.5 m along y, 0.5 Hz) and two 25 kg
 * slosh modes (along x at 0.30 Hz, along y at 0.35 Hz), each pair twice (4 records) */
static void parts(sr_plant_panel *flex, sr_plant_slosh *slosh)
{
    int i;
    memset(flex, 0, SR_PLANT_MAX_FLEX * sizeof *flex);
    memset(slosh, 0, SR_PLANT_MAX_SLOSH * sizeof *slosh);
    for (i = 0; i < SR_PLANT_MAX_FLEX; i++) {
        const double side = i % 2 ? -1.0 : 1.0;
        flex[i].m = 50.0;
        flex[i].com[0] = 2.5 * side;
        flex[i].Ixx = 10.67041666666667;
        flex[i].Iyy = 66.67041666666668;
        flex[i].Izz = 77.33333333333334;
        flex[i].hinge[0] = 0.5 * side;
        flex[i].axis[1] = 1.0;
        flex[i].f = 0.5;
        flex[i].zeta = 0.005;
    }
    for (i = 0; i < SR_PLANT_MAX_SLOSH; i++) {
        slosh[i].m = 25.0;
        slosh[i].r[0] = -0.2;
        slosh[i].r[1] = 0.1;
        slosh[i].r[2] = -0.4;
        slosh[i].axis[i % 2] = 1.0;
        slosh[i].f = i % 2 ? 0.35 : 0.3;
        slosh[i].zeta = 0.01;
    }
}

static void *run(void *arg)
{
    job *jb = arg;
    sr_robot *robot = calloc(1, sizeof *robot);
    sr_plant_model *model = calloc(1, sizeof *model);
    sr_plant_data *data = calloc(1, sizeof *data);
    double *y = calloc(SR_PLANT_MAX_NY, sizeof *y), F[3], M[3], tau[SR_MAX_JOINTS];
    double a[SR_PLANT_MAX_NV], flow, ref[3 * SR_PLANT_MAX_CHANNELS];
    char err[SR_PLANT_MSG_LEN];
    sr_body target = {250.0, {0.1, 0.05, 0.2}, {20.0, 0.0, 0.0, 0.0, 25.0, 0.0, 0.0, 0.0, 30.0}};
    const sr_plant_controller ctrl = {.F_max = 10.0, .K_F = -1.0, .P_max = 10.0, .M_max = 10.0,
                                      .K_M = -1.0, .L_max = 10.0, .K_D = 0.7071, .K_P = 0.25,
                                      .K_Dn = 1.0, .K_Pn = 0.25, .qdd_max = 1.0};
    sr_plant_excitation ex;
    sr_plant_propellant prop;
    sr_plant_panel flex[SR_PLANT_MAX_FLEX];
    sr_plant_slosh slosh[SR_PLANT_MAX_SLOSH];
    const double v0[3] = {1.0, 2.0, 3.0}, w0[3] = {0.1, 0.2, 0.3};
    int k, st;
    jb->status = 1;
    if (jb->hog)
        jb->y0 = hog(1 << 18);
    if (!robot || !model || !data || !y)
        return NULL;
    if (sr_robot_read(jb->record, robot, err, sizeof err) != 0) {
        printf("record: %s\n", err);
        return NULL;
    }
    memset(&ex, 0, sizeof ex);
    ex.att_max = 0.3; ex.q_max = 0.3; ex.qd_max = 0.2; ex.qdd_max = 0.1; ex.period = 8.0;
    ex.ramp = 1.0;
    memset(&prop, 0, sizeof prop);
    prop.m0 = 80.0; prop.Isp = 220.0; prop.R = 0.27; prop.arm = 1.0;
    prop.r[0] = 0.3; prop.r[1] = 0.2; prop.r[2] = -0.2;
    if (sr_plant_model_init(model, robot, &robot->base, &target, &ctrl, &ex, &prop, NULL, v0, w0,
                            1e-3, err, sizeof err) != 0) {
        printf("model: %s\n", err);
        return NULL;
    }
    parts(flex, slosh);
    if (sr_plant_model_set_leaves(model, 2, flex, 2, slosh, err, sizeof err) != 0) {
        printf("leaves: %s\n", err);
        return NULL;
    }
    if (sr_plant_start(model, data) != 0 || sr_plant_set_excitation(model, data, 1.0) != 0)
        return NULL;
    for (k = 0; k < 40; k++) {
        if (k == 15 && sr_plant_set_excitation_rate(model, data, 3.0) != 0)
            return NULL;
        if ((st = sr_plant_advance(model, data, 0.1)) != 0
            || (st = sr_plant_outputs(model, data, y)) != 0
            || (st = sr_plant_controls(model, data, F, M, tau, a, &flow)) != 0
            || (st = sr_plant_references(model, data, ref)) != 0) {
            printf("step %d: %s\n", k, sr_plant_status_message(st));
            return NULL;
        }
    }
    sr_plant_get_state(model, data, &jb->t, NULL, NULL);
    jb->y0 = y[0];
    jb->status = 0;
    free(robot);
    free(model);
    free(data);
    free(y);
    return NULL;
}

int main(int argc, char **argv)
{
    pthread_attr_t attr;
    pthread_t th;
    job jb;
    if (argc < 3) {
        fprintf(stderr, "usage: stack_plant RECORD STACK_BYTES [hog]\n");
        return 2;
    }
    memset(&jb, 0, sizeof jb);
    jb.record = argv[1];
    jb.hog = argc > 3 && strcmp(argv[3], "hog") == 0;
    if (pthread_attr_init(&attr) != 0
        || pthread_attr_setstacksize(&attr, (size_t)strtoul(argv[2], NULL, 10)) != 0
        || pthread_create(&th, &attr, run, &jb) != 0) {
        fprintf(stderr, "cannot start a thread with a %s-byte stack\n", argv[2]);
        return 3;
    }
    pthread_join(th, NULL);
    if (jb.status != 0)
        return 1;
    printf("ok %.17g %.17g\n", jb.t, jb.y0);
    return 0;
}
