/* A C user of the integrator's event interface, run under the sanitizers by
 * test_c_program.py: the pendulum latched at the bottom (a hinge lock with a plastic impact),
 * then stopped by a terminal event. Prints the events; exit code 0 when all went well. */
#include <stdio.h>
#include <string.h>

#include "core/include/depsim.h"
#include "model.h"

static int hinge_angle(void *context, double t, const double *q, const double *qd,
                       const dep_active_rows *rows, double *g)
{
    double theta[MODEL_NH > 0 ? MODEL_NH : 1];
    (void)context, (void)t, (void)qd, (void)rows;
    depsim_model.hinge_angles(q, depsim_model.parameter_defaults, theta);
    *g = theta[0];
    return 0;
}

static int late(void *context, double t, const double *q, const double *qd,
                const dep_active_rows *rows, double *g)
{
    (void)context, (void)q, (void)qd, (void)rows;
    *g = t - 0.9;
    return 0;
}

static int latch(void *context, const dep_event_hit *hit, dep_event_response *response)
{
    (void)context;
    response->n_add = 1;
    response->add[0].kind = DEP_ROW_HINGE_LOCK;
    response->add[0].hinge = 0;
    response->add[0].angle = 0.0;
    response->impact = 1;
    response->n_data = 1;
    strcpy(response->data_names[0], "omega");
    response->data_values[0] = hit->qd[2];
    return 0;
}

int main(void)
{
    dep_event events[2] = {
        {"bottom", hinge_angle, -1, latch, NULL, 0, 1, 0},
        {"late", late, 1, NULL, NULL, 1, -1, 0},
    };
    dep_settings settings = dep_default_settings(&depsim_model);
    dep_result result;
    dep_error error;
    settings.t_end = 2.0;
    if (dep_simulate(&depsim_model, NULL, &settings, events, 2, &result, &error) != DEP_OK) {
        fprintf(stderr, "%s\n", error.message);
        return 1;
    }
    for (int k = 0; k < result.n_events; ++k) {
        printf("%s %.17g %d\n", result.events[k].name, result.events[k].t, result.n_rows);
    }
    int ok = result.n_events == 2 && result.n_rows == 3;
    dep_result_free(&result);
    return ok ? 0 : 1;
}
