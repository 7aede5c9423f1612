/* recording.c: samples the solution at the output times and assembles the result's
 * arrays (docs/method.md, 5).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"

/* The most output times a run records: at most DEP_MAX_OUTPUT_TIMES, and at most
   DEP_MAX_OUTPUT_BYTES of recorded rows (the Python side copies them once more). */
#define DEP_MAX_OUTPUT_TIMES 10000000.0
#define DEP_MAX_OUTPUT_BYTES 1073741824.0 /* 1 GiB */

static double row_bytes(const dep_system *system)
{
    const dep_model *m = system->model;
    return 8.0 * (1 + 2 * m->nq + 5 * m->nh + m->nout + 3 + system->ne + system->nd);
}

double dep_max_output_times(const dep_system *system)
{
    return fmin(DEP_MAX_OUTPUT_TIMES, floor(DEP_MAX_OUTPUT_BYTES / row_bytes(system)));
}

/* Room for `capacity` recorded multipliers (their values and row-name ids), those kept so far
   copied. */
static int grow_multipliers(dep_recorder *rec, int capacity)
{
    int *ids = dep_bytes(rec->arena, (size_t)capacity * sizeof *ids);
    double *values = dep_doubles(rec->arena, (size_t)capacity);
    if (ids == NULL || values == NULL) {
        return DEP_MEMORY_ERROR;
    }
    if (rec->lam_count) {
        memcpy(ids, rec->lam_ids, (size_t)rec->lam_count * sizeof *ids);
        memcpy(values, rec->lam_values, (size_t)rec->lam_count * sizeof *values);
    }
    rec->lam_ids = ids;
    rec->lam_values = values;
    rec->lam_capacity = capacity;
    return DEP_OK;
}

/* 0, dt_out, 2 dt_out, ... up to t_end, with t_end itself always last (s). */
static int output_times(double t_end, double dt_out, double limit, double **times,
                        dep_arena *arena)
{
    double ratio = floor(t_end / dt_out * (1 + 1e-12));
    if (!(ratio + 2 <= limit)) {
        return DEP_SETTINGS_ERROR;
    }
    int count = (int)ratio, n = count + 1;
    double *t = *times = dep_doubles(arena, (size_t)n + 1);
    if (t == NULL) {
        return DEP_MEMORY_ERROR;
    }
    for (int k = 0; k <= count; ++k) {
        t[k] = k * dt_out;
    }
    if (t_end - t[count] > 1e-9 * dt_out) {
        t[n++] = t_end;
    } else {
        t[count] = t_end;
    }
    return -n; /* negative: the count */
}

int dep_recorder_init(dep_recorder *rec, const dep_system *system, dep_mechanism *mechanism,
                      const dep_settings *settings, int capacity, dep_arena *arena)
{
    const dep_model *m = system->model;
    memset(rec, 0, sizeof *rec);
    rec->system = system;
    rec->mechanism = mechanism;
    rec->arena = arena;
    rec->outputs_only = settings->rows == DEP_ROWS_OUTPUTS;
    int n = output_times(settings->t_end, settings->dt_out, dep_max_output_times(system),
                         &rec->times, arena);
    if (n >= 0) {
        return n;
    }
    rec->n_times = -n;
    size_t rows = (size_t)(rec->capacity = rec->n_times + 1), nq = (size_t)m->nq;
    rec->t = dep_doubles(arena, rows);
    rec->outputs = dep_doubles(arena, rows * (size_t)m->nout);
    rec->work = dep_doubles(arena, rows * (size_t)system->nd);
    rec->force = dep_doubles(arena, rows * DEP_FORCE_ROWS * (size_t)m->nh);
    rec->torque = dep_doubles(arena, rows * (size_t)m->nh);
    rec->force_rows = dep_bytes(arena, (DEP_FORCE_ROWS * (size_t)m->nh + 1)
                                       * sizeof *rec->force_rows);
    if (rec->force_rows != NULL) {
        dep_hinge_force_rows(m, rec->force_rows);
    }
    rec->lam_start = dep_bytes(arena, (rows + 1) * sizeof *rec->lam_start);
    if (!rec->outputs_only) { /* (the columns the outputs' rows leave nought: not touched) */
        rec->q = dep_doubles(arena, rows * nq);
        rec->qd = dep_doubles(arena, rows * nq);
        rec->hinge_angles = dep_doubles(arena, rows * (size_t)m->nh);
        rec->hinge_rates = dep_doubles(arena, rows * (size_t)m->nh);
        rec->residuals = dep_doubles(arena, rows * 3);
        rec->energy = dep_doubles(arena, rows * (size_t)system->ne);
        rec->system_state = dep_doubles(arena, rows * (size_t)m->nsys);
    }
    if (grow_multipliers(rec, (int)(rows * (size_t)m->nc)) != DEP_OK) {
        return DEP_MEMORY_ERROR; /* room for the model's rows at every output time */
    }
    rec->f = dep_doubles(arena, nq);
    rec->qdd = dep_doubles(arena, nq);
    rec->J = dep_doubles(arena, DEP_JACOBIAN_SIZE(m));
    rec->v = dep_doubles(arena, (size_t)capacity);
    rec->w = dep_doubles(arena, DEP_RUN_VALUES(m) + 1);
    rec->energy_scratch = dep_doubles(arena, (size_t)system->ne + 1);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

double dep_impact_loss(const dep_event_record *records, int n)
{
    double total = 0.0;
    for (int e = 0; e < n; ++e) {
        for (int i = 0; i < records[e].n_data; ++i) {
            const dep_datum *d = &records[e].data[i];
            if (d->kind == DEP_NUMBER && d->member[0] == '\0'
                && strcmp(d->key, "impact_energy_loss") == 0) {
                total += d->number;
            }
        }
    }
    return total;
}

void dep_run_values(const dep_system *system, const double *q, const double *torques,
                    const double *work, double impacts, double *energy, double *w)
{
    const dep_model *m = system->model;
    int nh = m->nh, nd = m->nd, n_friction = system->n_friction;
    for (int k = 0; k < nh; ++k) { /* (0 while nothing holds the hinge) */
        w[k] = isnan(torques[k]) ? 0.0 : torques[k];
    }
    for (int d = 0; d < nd; ++d) {
        w[nh + d] = work[d];
    }
    double *totals = w + nh + nd;
    totals[0] = totals[1] = totals[3] = 0.0;
    for (int d = nd; d < nd + n_friction; ++d) { /* "friction.<h>" */
        totals[0] += work[d];
    }
    for (int d = nd + n_friction; d < system->nd; ++d) { /* "latch.<h>" */
        totals[1] += work[d];
    }
    totals[2] = impacts;
    if (system->n_compliant > 0) { /* the latches' potential energy, after the model's */
        dep_hinge_energy(system, q, energy);
        for (int e = m->ne; e < system->ne; ++e) {
            totals[3] += energy[e];
        }
    }
}

/* Output times not yet recorded that are <= t_until: returns how many, from times[*first]. */
int dep_recorder_pending(dep_recorder *rec, double t_until, int *first)
{
    double slack = 1e-12 * fmax(1.0, fabs(t_until));
    *first = rec->next_index;
    while (rec->next_index < rec->n_times && rec->times[rec->next_index] <= t_until + slack) {
        rec->next_index++;
    }
    return rec->next_index - *first;
}

double dep_recorder_last_time(const dep_recorder *rec)
{
    return rec->rows ? rec->t[rec->rows - 1] : NAN;
}

/* The id of a row name (new names appended); `hint`: where it usually is (the row's index,
   as the model's rows come first in every active set), tried first. */
static int name_index(dep_recorder *rec, const char *name, int hint)
{
    if (hint < rec->n_names && strcmp(rec->names[hint], name) == 0) {
        return hint;
    }
    for (int i = 0; i < rec->n_names; ++i) {
        if (strcmp(rec->names[i], name) == 0) {
            return i;
        }
    }
    if (rec->n_names == rec->names_capacity) {
        int capacity = rec->names_capacity ? 2 * rec->names_capacity : 32;
        char **names = dep_bytes(rec->arena, (size_t)capacity * sizeof *names);
        if (names == NULL) {
            return -1;
        }
        if (rec->n_names) {
            memcpy(names, rec->names, (size_t)rec->n_names * sizeof *names);
        }
        rec->names = names;
        rec->names_capacity = capacity;
    }
    char *copy = dep_bytes(rec->arena, strlen(name) + 1);
    if (copy == NULL) {
        return -1;
    }
    strcpy(copy, name);
    rec->names[rec->n_names] = copy;
    return rec->n_names++;
}

static int keep_multipliers(dep_recorder *rec, const double *lam, const dep_constraints *cs)
{
    if (rec->lam_count + cs->nc > rec->lam_capacity
        && grow_multipliers(rec, 2 * (rec->lam_count + cs->nc) + 64) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    for (int i = 0; i < cs->nc; ++i) {
        int id = name_index(rec, cs->row_names[i], i);
        if (id < 0) {
            return DEP_MEMORY_ERROR;
        }
        rec->lam_ids[rec->lam_count] = id;
        rec->lam_values[rec->lam_count++] = lam[i];
    }
    return DEP_OK;
}

/* Store the row for time t (s) with the multipliers lam of the active rows. */
int dep_record(dep_recorder *rec, double t, const double *q, const double *qd, const double *lam,
               const double *work, dep_constraints *cs)
{
    const dep_system *s = rec->system;
    const dep_model *m = s->model;
    size_t row = (size_t)rec->rows, nq = (size_t)m->nq;
    int nc = cs->nc;
    if (rec->rows == rec->capacity) {
        return DEP_MEMORY_ERROR; /* cannot happen: one row per output time, one at a stop */
    }
    rec->lam_start[row] = rec->lam_count;
    if (keep_multipliers(rec, lam, cs) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    rec->t[row] = t;
    memcpy(rec->work + row * (size_t)s->nd, work, (size_t)s->nd * sizeof(double));
    for (int k = 0; k < m->nh; ++k) { /* (the model's rows come first in cs) */
        dep_hinge_force(rec->force_rows + DEP_FORCE_ROWS * k, lam,
                        rec->force + (row * (size_t)m->nh + (size_t)k) * DEP_FORCE_ROWS);
    }
    double *torques = rec->torque + row * (size_t)m->nh;
    if (rec->mechanism != NULL) {
        dep_mechanism_hinge_torques(rec->mechanism, q, qd, cs, lam, torques);
    } else {
        dep_lock_torques(m, cs, lam, torques);
    }
    if (rec->records != NULL && *rec->n_records > rec->impacts_counted) { /* new records */
        rec->impacts += dep_impact_loss(*rec->records + rec->impacts_counted,
                                        *rec->n_records - rec->impacts_counted);
        rec->impacts_counted = *rec->n_records;
    }
    dep_run_values(s, q, torques, work, rec->impacts, rec->energy_scratch, rec->w);
    m->outputs(q, qd, t, s->p, lam, rec->w, rec->outputs + row * (size_t)m->nout);
    rec->rows++;
    rec->lam_start[rec->rows] = rec->lam_count;
    if (rec->outputs_only) {
        return DEP_OK;
    }
    dep_system_force(s, q, qd, t, rec->f);
    dep_cs_jacobian(cs, q, t, rec->J);
    dep_cs_transpose_times(cs, rec->J, lam, rec->qdd);
    for (size_t j = 0; j < nq; ++j) { /* qdd = M^-1 (f - J^T lam) */
        rec->f[j] -= rec->qdd[j];
    }
    dep_mass_solve(&s->mass, rec->f, rec->qdd);
    double *residuals = rec->residuals + 3 * row;
    dep_cs_phi(cs, q, t, rec->v);
    residuals[0] = dep_max_abs(rec->v, nc);
    dep_cs_v_vel(cs, q, qd, t, rec->J, rec->v);
    residuals[1] = dep_max_abs(rec->v, nc);
    dep_cs_v_acc(cs, q, qd, rec->qdd, t, rec->J, rec->v);
    residuals[2] = dep_max_abs(rec->v, nc);
    memcpy(rec->q + row * nq, q, nq * sizeof(double));
    memcpy(rec->qd + row * nq, qd, nq * sizeof(double));
    m->hinge_angles(q, s->p, rec->hinge_angles + row * (size_t)m->nh);
    m->hinge_rates(q, qd, s->p, rec->hinge_rates + row * (size_t)m->nh);
    dep_system_energy(s, q, qd, t, rec->energy + row * (size_t)s->ne);
    if (m->nsys > 0) {
        m->system_state(q, qd, s->p, rec->system_state + row * (size_t)m->nsys);
    }
    return DEP_OK;
}

/* ---- the result ------------------------------------------------------------------------- */

double *dep_copy_doubles(const double *from, size_t n, int *failed)
{
    double *to = malloc((n ? n : 1) * sizeof *to);
    if (to == NULL) {
        *failed = 1;
        return NULL;
    }
    if (n) {
        memcpy(to, from, n * sizeof *to);
    }
    return to;
}

/* A column the rows kept (copy_doubles), or nought when they did not (DEP_ROWS_OUTPUTS). */
static double *kept_doubles(const dep_recorder *rec, const double *from, size_t n, int *failed)
{
    if (!rec->outputs_only) {
        return dep_copy_doubles(from, n, failed);
    }
    double *to = calloc(n ? n : 1, sizeof *to);
    *failed |= to == NULL;
    return to;
}

static char **copy_names(const char *const *names, int n, int *failed)
{
    char **copy = calloc((size_t)(n ? n : 1), sizeof *copy);
    *failed |= copy == NULL;
    for (int i = 0; copy != NULL && i < n; ++i) {
        copy[i] = malloc(strlen(names[i]) + 1);
        *failed |= copy[i] == NULL;
        if (copy[i] != NULL) {
            strcpy(copy[i], names[i]);
        }
    }
    return copy;
}

static void free_names(char **names, int n)
{
    for (int i = 0; names != NULL && i < n; ++i) {
        free(names[i]);
    }
    free(names);
}

static double *dense_multipliers(const dep_recorder *rec, int *failed)
{
    size_t size = (size_t)rec->rows * (size_t)rec->n_names;
    double *lam = malloc((size ? size : 1) * sizeof *lam);
    if (lam == NULL) {
        *failed = 1;
        return NULL;
    }
    for (size_t k = 0; k < size; ++k) {
        lam[k] = NAN;
    }
    for (int r = 0; r < rec->rows; ++r) {
        for (int k = rec->lam_start[r]; k < rec->lam_start[r + 1]; ++k) {
            lam[(size_t)r * (size_t)rec->n_names + (size_t)rec->lam_ids[k]] = rec->lam_values[k];
        }
    }
    return lam;
}

/* The recorded rows as a dep_result (malloc'ed; dep_result_free releases them). */
int dep_recorder_result(dep_recorder *rec, dep_result *result)
{
    const dep_model *m = rec->system->model;
    size_t n = (size_t)rec->rows;
    int failed = 0;
    result->n = rec->rows;
    result->nq = m->nq;
    result->nh = m->nh;
    result->nout = m->nout;
    result->ne = rec->system->ne;
    result->nd = rec->system->nd;
    result->n_rows = rec->n_names;
    result->row_names = copy_names((const char *const *)rec->names, rec->n_names, &failed);
    result->params = dep_copy_doubles(rec->system->p, (size_t)m->np, &failed);
    result->times = dep_copy_doubles(rec->t, n, &failed);
    result->q = kept_doubles(rec, rec->q, n * (size_t)m->nq, &failed);
    result->qd = kept_doubles(rec, rec->qd, n * (size_t)m->nq, &failed);
    result->lam = dense_multipliers(rec, &failed);
    result->hinge_angles = kept_doubles(rec, rec->hinge_angles, n * (size_t)m->nh, &failed);
    result->hinge_rates = kept_doubles(rec, rec->hinge_rates, n * (size_t)m->nh, &failed);
    result->outputs = dep_copy_doubles(rec->outputs, n * (size_t)m->nout, &failed);
    result->energy = kept_doubles(rec, rec->energy, n * (size_t)result->ne, &failed);
    result->nsys = m->nsys;
    result->system_state = kept_doubles(rec, rec->system_state, n * (size_t)m->nsys, &failed);
    result->dissipated = dep_copy_doubles(rec->work, n * (size_t)result->nd, &failed);
    result->hinge_force = dep_copy_doubles(rec->force, n * DEP_FORCE_ROWS * (size_t)m->nh, &failed);
    result->hinge_torque = dep_copy_doubles(rec->torque, n * (size_t)m->nh, &failed);
    result->energy_names = copy_names(rec->system->energy_names, result->ne, &failed);
    result->dissipator_names = copy_names(rec->system->dissipator_names, result->nd, &failed);
    double **levels[3] = {&result->residual_pos, &result->residual_vel, &result->residual_acc};
    for (int level = 0; level < 3; ++level) {
        double *column = *levels[level] = calloc(n ? n : 1, sizeof(double));
        failed |= column == NULL;
        for (size_t r = 0; column != NULL && !rec->outputs_only && r < n; ++r) {
            column[r] = rec->residuals[3 * r + (size_t)level];
        }
    }
    return failed ? DEP_MEMORY_ERROR : DEP_OK;
}

void dep_result_free(dep_result *result)
{
    if (result == NULL) {
        return;
    }
    free_names(result->row_names, result->n_rows);
    free_names(result->energy_names, result->ne);
    free_names(result->dissipator_names, result->nd);
    double *arrays[] = {result->params, result->times, result->q, result->qd, result->lam,
                        result->hinge_angles, result->hinge_rates, result->outputs,
                        result->residual_pos, result->residual_vel, result->residual_acc,
                        result->energy, result->dissipated, result->hinge_force,
                        result->hinge_torque, result->system_state, result->sensitivity_state,
                        result->sensitivity_outputs, result->sensitivity_events,
                        result->sensitivity_lam};
    for (size_t i = 0; i < sizeof arrays / sizeof *arrays; ++i) {
        free(arrays[i]);
    }
    for (int k = 0; result->events != NULL && k < result->n_events; ++k) {
        free(result->events[k].data);
    }
    free(result->events);
    free(result->peak_loads);
    free(result->deployment.latch_hinges);
    free(result->deployment.latches);
    free(result->report);
    free(result->sensitivity_params);
    memset(result, 0, sizeof *result);
}
