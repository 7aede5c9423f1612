/* fmi2_variables.c: getting and setting the FMU's variables by value reference (fmu.h, the
 * tables of fmu_variables.c): parameters, inputs and their rates, outputs, each hinge's
 * observables; the derivatives FMI asks of them are not supported.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmu.h"
#include "model.h"

/* ---- getting and setting values --------------------------------------------------------- */

/* Whether `vr` is one of `count` value references 0, 1, ... */
static int known(fmi2ValueReference vr, int count)
{
    return (unsigned long)vr < (unsigned long)count;
}

static int arrays_given(fmu_instance *fmu, const char *function, size_t nvr,
                        const void *vr, const void *value)
{
    if (nvr > 0 && (vr == NULL || value == NULL)) {
        fmu_fail(fmu, "%s: vr or value is NULL (nvr = %lu)", function, (unsigned long)nvr);
        return 0;
    }
    return 1;
}

static double hinge_value(const dep_hinge_state *hinge, enum fmu_kind kind)
{
    switch (kind) {
    case FMU_ANGLE: return hinge->angle;
    case FMU_RATE: return hinge->rate;
    case FMU_FORCE_X: return hinge->force_x;
    case FMU_FORCE_Y: return hinge->force_y;
    case FMU_FORCE_Z: return hinge->force_z;
    case FMU_TORQUE: return hinge->torque;
    default: return NAN;
    }
}

static double real_value(const fmu_instance *fmu, const fmu_variable *var)
{
    switch (var->kind) {
    case FMU_TIME: return fmu->time;
    case FMU_PARAMETER: return fmu->params[var->index];
    case FMU_INPUT: return fmu->params[fmu_input_slots[var->index]];
    case FMU_OUTPUT: return fmu->outputs[var->index];
    default: return hinge_value(&fmu->hinges[var->index], var->kind);
    }
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetReal", READABLE);
    if (fmu == NULL || !arrays_given(fmu, "fmi2GetReal", nvr, vr, value))
        return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
        if (!known(vr[k], fmu_nreal))
            return fmu_fail(fmu, "fmi2GetReal: unknown value reference %u (Real variables have "
                        "0 to %d)", vr[k], fmu_nreal - 1);
    if (fmu_current_results(fmu) != fmi2OK)
        return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
        value[k] = real_value(fmu, &fmu_real_variables[vr[k]]);
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetBoolean", READABLE);
    if (fmu == NULL || !arrays_given(fmu, "fmi2GetBoolean", nvr, vr, value))
        return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
        if (!known(vr[k], fmu_nboolean))
            return fmu_fail(fmu, "fmi2GetBoolean: unknown value reference %u (this FMU has %d "
                        "Boolean variables)", vr[k], fmu_nboolean);
    if (fmu_current_results(fmu) != fmi2OK)
        return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
        value[k] = fmu->hinges[fmu_boolean_variables[vr[k]].index].latched ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetInteger", READABLE);
    if (fmu == NULL || !arrays_given(fmu, "fmi2GetInteger", nvr, vr, value))
        return fmi2Error;
    if (nvr > 0)
        return fmu_fail(fmu, "fmi2GetInteger: unknown value reference %u (this FMU has no "
                    "Integer variables)", vr[0]);
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetString", READABLE);
    if (fmu == NULL || !arrays_given(fmu, "fmi2GetString", nvr, vr, value))
        return fmi2Error;
    if (nvr > 0)
        return fmu_fail(fmu, "fmi2GetString: unknown value reference %u (this FMU has no "
                    "String variables)", vr[0]);
    return fmi2OK;
}

/* Check one fmi2SetReal / fmi2SetRealInputDerivatives target: the variable, or NULL after
   reporting why it cannot be set now. */
static const fmu_variable *settable(fmu_instance *fmu, const char *function,
                                    fmi2ValueReference vr, double value)
{
    if (!known(vr, fmu_nreal)) {
        fmu_fail(fmu, "%s: unknown value reference %u (Real variables have 0 to %d)", function,
             vr, fmu_nreal - 1);
        return NULL;
    }
    const fmu_variable *var = &fmu_real_variables[vr];
    if (var->kind != FMU_PARAMETER && var->kind != FMU_INPUT) {
        fmu_fail(fmu, "%s: '%s' is %s; only parameters and inputs can be set", function,
             var->name, var->kind == FMU_TIME ? "the independent variable" : "an output");
        return NULL;
    }
    if (var->kind == FMU_PARAMETER && !(fmu->phase & (PHASE_INSTANTIATED | PHASE_INITIALIZATION))) {
        fmu_fail(fmu, "%s: parameter '%s' is fixed once initialization ends; set it before "
             "fmi2ExitInitializationMode (or fmi2Reset and set it again)", function, var->name);
        return NULL;
    }
    if (!isfinite(value)) {
        fmu_fail(fmu, "%s: the value for '%s' is not a finite number", function, var->name);
        return NULL;
    }
    return var;
}

/* Store `value` in slot `slot` of p: before the run starts, the run will open with it; while
   stepping (inputs only), the run hears of it at the next fmi2DoStep. */
static void store(fmu_instance *fmu, int slot, double value)
{
    if (fmu->params[slot] == value)
        return;
    fmu->params[slot] = value;
    if (fmu->phase == PHASE_STEPPING)
        fmu->inputs_changed = 1;
    else
        fmu->run_current = 0;
}

/* The slot of p a settable variable holds. */
static int slot(const fmu_variable *var)
{
    return var->kind == FMU_INPUT ? fmu_input_slots[var->index] : var->index;
}

/* The model text's range checks (a length > 0, a friction >= 0, ...) of the parameters as
   `nvr` values would leave them: those depending on the values of this call alone are
   applied now (a value that breaks one is refused, whatever is set later); the others, a
   pair set in two calls (stop_min < stop_max), when the run opens. */
static int in_range(fmu_instance *fmu, const char *function, const fmi2ValueReference vr[],
                    size_t nvr, const fmi2Real value[])
{
    dep_error error;
    memcpy(fmu->trial, fmu->params, MODEL_NP * sizeof(double));
    memset(fmu->given, 0, MODEL_NP);
    for (size_t k = 0; k < nvr; ++k) {
        int at = slot(&fmu_real_variables[vr[k]]);
        fmu->trial[at] = value[k];
        fmu->given[at] = 1;
    }
    if (dep_check_parameters(&depsim_model, fmu->trial, fmu->given, &error) != DEP_OK) {
        fmu_fail(fmu, "%s: %s", function, error.message);
        return 0;
    }
    return 1;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2SetReal", PHASE_INSTANTIATED | PHASE_INITIALIZATION
                                                | PHASE_STEPPING);
    if (fmu == NULL || !arrays_given(fmu, "fmi2SetReal", nvr, vr, value))
        return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
        if (settable(fmu, "fmi2SetReal", vr[k], value[k]) == NULL)
            return fmi2Error;
    if (!in_range(fmu, "fmi2SetReal", vr, nvr, value))
        return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
        store(fmu, slot(&fmu_real_variables[vr[k]]), value[k]);
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2SetInteger", PHASE_INSTANTIATED | PHASE_INITIALIZATION
                                                   | PHASE_STEPPING);
    if (fmu == NULL || !arrays_given(fmu, "fmi2SetInteger", nvr, vr, value))
        return fmi2Error;
    if (nvr > 0)
        return fmu_fail(fmu, "fmi2SetInteger: unknown value reference %u (this FMU has no "
                    "Integer variables)", vr[0]);
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2SetBoolean", PHASE_INSTANTIATED | PHASE_INITIALIZATION
                                                   | PHASE_STEPPING);
    if (fmu == NULL || !arrays_given(fmu, "fmi2SetBoolean", nvr, vr, value))
        return fmi2Error;
    if (nvr > 0 && known(vr[0], fmu_nboolean))
        return fmu_fail(fmu, "fmi2SetBoolean: '%s' is an output; it cannot be set",
                    fmu_boolean_variables[vr[0]].name);
    if (nvr > 0)
        return fmu_fail(fmu, "fmi2SetBoolean: unknown value reference %u (this FMU has %d "
                    "Boolean variables, all outputs)", vr[0], fmu_nboolean);
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2SetString", PHASE_INSTANTIATED | PHASE_INITIALIZATION
                                                  | PHASE_STEPPING);
    if (fmu == NULL || !arrays_given(fmu, "fmi2SetString", nvr, vr, value))
        return fmi2Error;
    if (nvr > 0)
        return fmu_fail(fmu, "fmi2SetString: unknown value reference %u (this FMU has no "
                    "String variables)", vr[0]);
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c,
                                        const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return fmu_unsupported(c, "fmi2GetDirectionalDerivative",
                       "providesDirectionalDerivative = false");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[])
{
    const char *function = "fmi2SetRealInputDerivatives";
    fmu_instance *fmu = fmu_enter(c, function, PHASE_INSTANTIATED | PHASE_INITIALIZATION
                                           | PHASE_STEPPING);
    if (fmu == NULL || !arrays_given(fmu, function, nvr, vr, value))
        return fmi2Error;
    if (nvr > 0 && order == NULL)
        return fmu_fail(fmu, "%s: order is NULL", function);
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *var = settable(fmu, function, vr[k], value[k]);
        if (var == NULL)
            return fmi2Error;
        if (var->kind != FMU_INPUT)
            return fmu_fail(fmu, "%s: '%s' is not an input", function, var->name);
        if (order[k] != 1)
            return fmu_fail(fmu, "%s: '%s': derivative order %d; this FMU interpolates inputs "
                        "linearly and takes order 1 only", function, var->name, order[k]);
    }
    for (size_t k = 0; k < nvr; ++k)
        store(fmu, fmu_input_slots[fmu_real_variables[vr[k]].index] + 1, value[k]);
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return fmu_unsupported(c, "fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder = 0");
}
