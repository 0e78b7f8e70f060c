/*
 * A tiny FMI 2.0 (and, at the end, FMI 3.0) Co-Simulation FMU used only by the host's tests and benches
 * (it is never shipped): a mass-spring-damper
 *
 *     m x'' + d x' + k x = F(t),   F(t) = F + dF/dt (t - t_step)   (first-order input interpolation)
 *
 * integrated by `substeps` RK4 steps per DoStep (substeps = 0: DoStep only
 * advances time, for measuring the master's own overhead). DoStep answers
 * fmi2Error once the step would pass `fail_at_s`, fmi2Discard once it would
 * pass `discard_at_s`, each with a logger message carrying printf arguments,
 * so that the host's variadic logger shim and its error path are exercised.
 *
 * Value references (all Real):
 *   0 m [kg], 1 k [N/m], 2 d [N s/m], 3 F input [N], 4 x output [m],
 *   5 v output [m/s], 6 fail_at_s, 7 discard_at_s, 8 substeps, 9 x0 [m]
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum { fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated } fmi2StatusKind;
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef struct {
    fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define EXPORT __attribute__((visibility("default")))
#define GUID "{host-test-osc-0001}"
#define NVR 10

typedef struct {
    double r[NVR];
    double dF;
    double t;
} State;

typedef struct {
    State s;
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    char name[64];
} Inst;

#define LOG(c, st, ...) do { if ((c)->logger) (c)->logger((c)->env, (c)->name, (st), "logAll", __VA_ARGS__); } while (0)

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String res,
                                     const fmi2CallbackFunctions *f, fmi2Boolean vis, fmi2Boolean log) {
    (void)res; (void)vis; (void)log;
    if (f == NULL) return NULL;
    if (type != fmi2CoSimulation || guid == NULL || strcmp(guid, GUID) != 0) {
        if (f->logger)
            f->logger(f->componentEnvironment, name ? name : "?", fmi2Error, "logStatusError",
                      "fmi2Instantiate: GUID mismatch: expected %s, got %s (type %d)", GUID, guid ? guid : "(null)", (int)type);
        return NULL;
    }
    Inst *c = calloc(1, sizeof(Inst));
    if (!c) return NULL;
    c->logger = f->logger;
    c->env = f->componentEnvironment;
    strncpy(c->name, name ? name : "?", sizeof c->name - 1);
    c->s.r[0] = 1.0; c->s.r[1] = 100.0; c->s.r[2] = 0.0;
    c->s.r[6] = INFINITY; c->s.r[7] = INFINITY; c->s.r[8] = 10.0;
    return c;
}

EXPORT void fmi2FreeInstance(fmi2Component c) { free(c); }
EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[]) {
    (void)c; (void)on; (void)n; (void)cats; return fmi2OK;
}
EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real stop) {
    (void)td; (void)tol; (void)sd; (void)stop; ((Inst *)c)->s.t = t0; return fmi2OK;
}
EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Inst *i = c;
    i->s.r[4] = i->s.r[9];
    if (!(i->s.r[0] > 0.0)) { LOG(i, fmi2Error, "mass must be positive, got %g kg", i->s.r[0]); return fmi2Error; }
    return fmi2OK;
}
EXPORT fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }
EXPORT fmi2Status fmi2Reset(fmi2Component c) { (void)c; return fmi2OK; }

EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= NVR) { LOG(i, fmi2Error, "fmi2GetReal: unknown value reference %u", vr[k]); return fmi2Error; }
        v[k] = i->s.r[vr[k]];
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= NVR || vr[k] == 4 || vr[k] == 5) { LOG(i, fmi2Error, "fmi2SetReal: value reference %u is not settable", vr[k]); return fmi2Error; }
        i->s.r[vr[k]] = v[k];
        if (vr[k] == 3) i->s.dF = 0.0;
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) { (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) { (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) { (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) { (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) { (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) { (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }

EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    if (*s == NULL) { *s = malloc(sizeof(State)); if (!*s) return fmi2Error; }
    memcpy(*s, &((Inst *)c)->s, sizeof(State));
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    if (!s) return fmi2Error;
    memcpy(&((Inst *)c)->s, s, sizeof(State));
    return fmi2OK;
}
EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; if (s) { free(*s); *s = NULL; } return fmi2OK; }
EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { (void)c; (void)s; *n = sizeof(State); return fmi2OK; }
EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    (void)c; if (n != sizeof(State)) return fmi2Error; memcpy(b, s, n); return fmi2OK;
}
EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) {
    (void)c; if (n != sizeof(State)) return fmi2Error;
    if (*s == NULL) *s = malloc(sizeof(State));
    memcpy(*s, b, n); return fmi2OK;
}
EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                               const fmi2ValueReference z[], size_t nz, const fmi2Real dz[], fmi2Real du[]) {
    (void)c; (void)u; (void)nu; (void)z; (void)nz; (void)dz; (void)du; return fmi2Error;
}
EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                              const fmi2Integer order[], const fmi2Real v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != 3 || order[k] != 1) { LOG(i, fmi2Error, "fmi2SetRealInputDerivatives: only dF/dt (vr 3, order 1), got vr %u order %d", vr[k], order[k]); return fmi2Error; }
        i->s.dF = v[k];
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                               const fmi2Integer order[], fmi2Real v[]) {
    (void)c; (void)vr; (void)n; (void)order; (void)v; return fmi2Error;
}

static void rhs(const State *s, double tau, double x, double v, double *dx, double *dv) {
    double F = s->r[3] + s->dF * tau;
    *dx = v;
    *dv = (F - s->r[1] * x - s->r[2] * v) / s->r[0];
}

EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp) {
    (void)nsp;
    Inst *i = c;
    State *s = &i->s;
    if (fabs(t - s->t) > 1e-9 * (1.0 + fabs(t))) {
        LOG(i, fmi2Error, "fmi2DoStep: expected currentCommunicationPoint = %.17g but was %.17g", s->t, t);
        return fmi2Error;
    }
    if (t + h > s->r[6]) {
        LOG(i, fmi2Error, "fmi2DoStep: injected failure at t = %g s (fail_at_s = %g)", t, s->r[6]);
        return fmi2Error;
    }
    if (t + h > s->r[7]) {
        LOG(i, fmi2Discard, "fmi2DoStep: injected discard at t = %g s (discard_at_s = %g)", t, s->r[7]);
        return fmi2Discard;
    }
    int n = (int)s->r[8];
    double x = s->r[4], v = s->r[5], dt = n > 0 ? h / n : 0.0;
    for (int k = 0; k < n; k++) {
        double tau = k * dt, k1x, k1v, k2x, k2v, k3x, k3v, k4x, k4v;
        rhs(s, tau, x, v, &k1x, &k1v);
        rhs(s, tau + 0.5 * dt, x + 0.5 * dt * k1x, v + 0.5 * dt * k1v, &k2x, &k2v);
        rhs(s, tau + 0.5 * dt, x + 0.5 * dt * k2x, v + 0.5 * dt * k2v, &k3x, &k3v);
        rhs(s, tau + dt, x + dt * k3x, v + dt * k3v, &k4x, &k4v);
        x += dt / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x);
        v += dt / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    s->r[3] += s->dF * h;
    s->r[4] = x;
    s->r[5] = v;
    s->t = t + h;
    return fmi2OK;
}
EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }
EXPORT fmi2Status fmi2GetStatus(fmi2Component c, fmi2StatusKind k, fmi2Status *v) { (void)c; (void)k; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, fmi2StatusKind k, fmi2Real *v) {
    if (k != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = ((Inst *)c)->s.t; return fmi2OK;
}
EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, fmi2StatusKind k, fmi2Integer *v) { (void)c; (void)k; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, fmi2StatusKind k, fmi2Boolean *v) { (void)c; (void)k; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, fmi2StatusKind k, fmi2String *v) { (void)c; (void)k; (void)v; return fmi2Discard; }

/*
 * The same oscillator behind the FMI 3.0 Co-Simulation API (the importer's
 * FMI 3.0 path is tested against this C implementation of the standard's
 * header, independent of the workspace's own export layer). Value
 * references as above, all Float64; instantiation token = the GUID. The FMI
 * 3.0 logger is not variadic: messages are formatted here. DoStep answers
 * fmi3Error past `fail_at_s` and fmi3Discard past `discard_at_s`.
 * fmi3GetDirectionalDerivative gives the (zero) feedthrough of x, v on F.
 */
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

typedef void *fmi3Instance;
typedef void *fmi3InstanceEnvironment;
typedef void *fmi3FMUState;
typedef uint32_t fmi3ValueReference;
typedef double fmi3Float64;
typedef int32_t fmi3Int32;
typedef bool fmi3Boolean;
typedef const char *fmi3String;
typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;
typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment, fmi3Status, fmi3String, fmi3String);

typedef struct {
    Inst base; /* base.logger unused: FMI 3.0 logs through log3 */
    fmi3LogMessageCallback log3;
    fmi3InstanceEnvironment env3;
} Inst3;

static void log3(Inst3 *i, fmi3Status st, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void log3(Inst3 *i, fmi3Status st, const char *fmt, ...) {
    if (!i->log3) return;
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    i->log3(i->env3, st, "logAll", buf);
}

EXPORT const char *fmi3GetVersion(void) { return "3.0"; }

EXPORT fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean vis,
                                                fmi3Boolean logging, fmi3Boolean eventMode, fmi3Boolean earlyReturn,
                                                const fmi3ValueReference req[], size_t nreq,
                                                fmi3InstanceEnvironment env, fmi3LogMessageCallback logger,
                                                void *intermediateUpdate) {
    (void)res; (void)vis; (void)logging; (void)req; (void)nreq; (void)intermediateUpdate;
    if (token == NULL || strcmp(token, GUID) != 0 || eventMode || earlyReturn) {
        if (logger) {
            char buf[256];
            snprintf(buf, sizeof buf, "fmi3InstantiateCoSimulation: token mismatch: expected %s, got %s", GUID,
                     token ? token : "(null)");
            logger(env, fmi3Error, "logStatusError", buf);
        }
        return NULL;
    }
    Inst3 *c = calloc(1, sizeof(Inst3));
    if (!c) return NULL;
    c->log3 = logger;
    c->env3 = env;
    strncpy(c->base.name, name ? name : "?", sizeof c->base.name - 1);
    c->base.s.r[0] = 1.0; c->base.s.r[1] = 100.0; c->base.s.r[2] = 0.0;
    c->base.s.r[6] = INFINITY; c->base.s.r[7] = INFINITY; c->base.s.r[8] = 10.0;
    return c;
}

EXPORT void fmi3FreeInstance(fmi3Instance c) { free(c); }
EXPORT fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean td, fmi3Float64 tol, fmi3Float64 t0,
                                              fmi3Boolean sd, fmi3Float64 stop) {
    (void)td; (void)tol; (void)sd; (void)stop; ((Inst3 *)c)->base.s.t = t0; return fmi3OK;
}
EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    Inst3 *i = c;
    i->base.s.r[4] = i->base.s.r[9];
    if (!(i->base.s.r[0] > 0.0)) { log3(i, fmi3Error, "mass must be positive, got %g kg", i->base.s.r[0]); return fmi3Error; }
    return fmi3OK;
}
EXPORT fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }

EXPORT fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst3 *i = c;
    if (nv != n) { log3(i, fmi3Error, "fmi3GetFloat64: %zu values for %zu value references", nv, n); return fmi3Error; }
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= NVR) { log3(i, fmi3Error, "fmi3GetFloat64: unknown value reference %u", vr[k]); return fmi3Error; }
        v[k] = i->base.s.r[vr[k]];
    }
    return fmi3OK;
}
EXPORT fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Inst3 *i = c;
    if (nv != n) { log3(i, fmi3Error, "fmi3SetFloat64: %zu values for %zu value references", nv, n); return fmi3Error; }
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= NVR || vr[k] == 4 || vr[k] == 5) { log3(i, fmi3Error, "fmi3SetFloat64: value reference %u is not settable", vr[k]); return fmi3Error; }
        i->base.s.r[vr[k]] = v[k];
    }
    return fmi3OK;
}
EXPORT fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int32 v[], size_t nv) { (void)c; (void)vr; (void)v; (void)nv; return n ? fmi3Error : fmi3OK; }
EXPORT fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Int32 v[], size_t nv) { (void)c; (void)vr; (void)v; (void)nv; return n ? fmi3Error : fmi3OK; }
EXPORT fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Boolean v[], size_t nv) { (void)c; (void)vr; (void)v; (void)nv; return n ? fmi3Error : fmi3OK; }
EXPORT fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Boolean v[], size_t nv) { (void)c; (void)vr; (void)v; (void)nv; return n ? fmi3Error : fmi3OK; }
EXPORT fmi3Status fmi3SetString(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3String v[], size_t nv) { (void)c; (void)vr; (void)v; (void)nv; return n ? fmi3Error : fmi3OK; }

EXPORT fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *s) { return fmi2GetFMUstate(&((Inst3 *)c)->base, s) == fmi2OK ? fmi3OK : fmi3Error; }
EXPORT fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState s) { return fmi2SetFMUstate(&((Inst3 *)c)->base, s) == fmi2OK ? fmi3OK : fmi3Error; }
EXPORT fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *s) { (void)c; if (s) { free(*s); *s = NULL; } return fmi3OK; }

EXPORT fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
                                           const fmi3Int32 order[], fmi3Float64 v[], size_t nv) {
    (void)c; (void)vr; (void)order; (void)v; (void)nv; return n ? fmi3Error : fmi3OK;
}
EXPORT fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nu,
                                               const fmi3ValueReference knowns[], size_t nk, const fmi3Float64 seed[],
                                               size_t ns, fmi3Float64 sens[], size_t nsens) {
    Inst3 *i = c;
    (void)seed;
    if (ns != nk || nsens != nu) { log3(i, fmi3Error, "fmi3GetDirectionalDerivative: %zu seeds for %zu knowns, %zu sensitivities for %zu unknowns", ns, nk, nsens, nu); return fmi3Error; }
    for (size_t k = 0; k < nk; k++)
        if (knowns[k] != 3) { log3(i, fmi3Error, "fmi3GetDirectionalDerivative: only with respect to F (vr 3), got %u", knowns[k]); return fmi3Error; }
    for (size_t u = 0; u < nu; u++) {
        if (unknowns[u] != 4 && unknowns[u] != 5) { log3(i, fmi3Error, "fmi3GetDirectionalDerivative: only of x, v (vr 4, 5), got %u", unknowns[u]); return fmi3Error; }
        sens[u] = 0.0; /* x and v are states: no feedthrough from F */
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean nsp, fmi3Boolean *event,
                             fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    (void)nsp;
    Inst3 *i = c;
    State *s = &i->base.s;
    *event = false; *terminate = false; *early = false; *last = t;
    if (fabs(t - s->t) > 1e-9 * (1.0 + fabs(t))) {
        log3(i, fmi3Error, "fmi3DoStep: expected currentCommunicationPoint = %.17g but was %.17g", s->t, t);
        return fmi3Error;
    }
    if (t + h > s->r[6]) { log3(i, fmi3Error, "fmi3DoStep: injected failure at t = %g s (fail_at_s = %g)", t, s->r[6]); return fmi3Error; }
    if (t + h > s->r[7]) { log3(i, fmi3Discard, "fmi3DoStep: injected discard at t = %g s (discard_at_s = %g)", t, s->r[7]); return fmi3Discard; }
    s->dF = 0.0; /* FMI 3.0 has no input derivatives: inputs held over the step */
    if (fmi2DoStep(&i->base, t, h, 0) != fmi2OK) return fmi3Error;
    *last = t + h;
    return fmi3OK;
}
