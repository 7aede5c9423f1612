/* tally.c: a run's work and accuracy counters, frozen into dep_stats at the end.
 */
#include <math.h>
#include <string.h>

#include "run.h"

void dep_tally_init(dep_tally *tally)
{
    memset(tally, 0, sizeof *tally);
    tally->min_step = INFINITY;
}

/* Residual and CG work of a pass outside a step (initial state, after events). */
void dep_tally_observe(dep_tally *tally, const dep_pass_report *report)
{
    tally->cg_iterations += report->cg_iterations;
    tally->residuals[report->stage] = fmax(tally->residuals[report->stage], report->residual);
}

/* An accepted step of size h (s) with one report per pass. */
void dep_tally_accept(dep_tally *tally, const dep_pass_report reports[3], double h)
{
    tally->accepted++;
    tally->min_step = fmin(tally->min_step, h);
    tally->max_step = fmax(tally->max_step, h);
    for (int k = 0; k < 3; ++k) {
        int stage = reports[k].stage;
        dep_tally_observe(tally, &reports[k]);
        tally->totals[stage] += reports[k].iterations;
        if (reports[k].iterations > tally->maxima[stage]) {
            tally->maxima[stage] = reports[k].iterations;
        }
    }
}

static dep_pass_stats pass_stats(const dep_tally *tally, int stage)
{
    dep_pass_stats stats;
    stats.mean = tally->accepted ? (double)tally->totals[stage] / (double)tally->accepted : 0.0;
    stats.max = tally->maxima[stage];
    stats.total = tally->totals[stage];
    return stats;
}

dep_stats dep_tally_stats(const dep_tally *tally, long long integrations,
                          long long rhs_evaluations)
{
    dep_stats stats;
    memset(&stats, 0, sizeof stats);
    stats.accepted_steps = tally->accepted;
    stats.rejected_steps = tally->rejected;
    stats.failed_steps = tally->failed;
    stats.integrations = integrations;
    stats.rhs_evaluations = rhs_evaluations;
    stats.position = pass_stats(tally, DEP_POSITION);
    stats.velocity = pass_stats(tally, DEP_VELOCITY);
    stats.acceleration = pass_stats(tally, DEP_ACCELERATION);
    stats.cg_iterations = tally->cg_iterations;
    stats.factorizations = 0;
    stats.max_v_pos = tally->residuals[DEP_POSITION];
    stats.max_v_vel = tally->residuals[DEP_VELOCITY];
    stats.max_v_acc = tally->residuals[DEP_ACCELERATION];
    stats.min_step = tally->accepted ? tally->min_step : 0.0;
    stats.max_step = tally->max_step;
    stats.events = tally->events;
    return stats;
}
