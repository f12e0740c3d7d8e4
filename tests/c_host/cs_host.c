/* A minimal FMI 2.0 Co-Simulation host in C, compiled against the standard fmi2 headers (the
 * ones fmpy ships in fmpy/c-code/): it loads an unzipped FMU's binaries/linux64/scm.so with
 * dlopen, runs it through the C ABI and writes the outputs as CSV.
 *
 *   cs_host FMU_DIR GUID STOP STEP OUT.csv INPUTS OUTPUTS
 *     INPUTS   "vr=value,vr=value" (set before initialization; "" for none)
 *     OUTPUTS  "vr,vr,..." (written after every step, as %.17g)
 *
 * Communication points follow fmpy's simulate_fmu (t_k = k * STEP, step = t_(k+1) - t_k), so
 * the results can be compared with fmpy's run bit for bit. Along the way it also checks, and
 * fails (exit status 1) otherwise: every log message comes with the format "%s"; at half time
 * the FMU state is saved, serialized and deserialized, and the second half rerun from the
 * deserialized state gives the same outputs bit for bit.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

static int log_count = 0;
static int bad_format = 0;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category, fmi2String message, ...) {
    (void)env;
    va_list args;
    va_start(args, message);
    if (strcmp(message, "%s") != 0) {
        bad_format = 1;
        fprintf(stderr, "logger: format is not \"%%s\": %s\n", message);
    } else {
        const char *text = va_arg(args, const char *);
        fprintf(stderr, "[%s] %s (status %d): %s\n", instance, category, (int)status, text);
    }
    va_end(args);
    log_count++;
}

#define LOAD(name)                                                              \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);                         \
    if (!name) {                                                                \
        fprintf(stderr, "missing symbol %s: %s\n", #name, dlerror());          \
        return 1;                                                               \
    }

#define CHECK(call)                                                             \
    do {                                                                        \
        fmi2Status s_ = (call);                                                 \
        if (s_ != fmi2OK) {                                                     \
            fprintf(stderr, "%s:%d: %s returned %d\n", __FILE__, __LINE__, #call, (int)s_); \
            return 1;                                                           \
        }                                                                       \
    } while (0)

static size_t parse_list(const char *text, fmi2ValueReference *vrs, double *values, size_t max) {
    size_t n = 0;
    const char *p = text;
    while (*p && n < max) {
        char *end;
        vrs[n] = (fmi2ValueReference)strtoul(p, &end, 10);
        if (values) {
            if (*end != '=') return n;
            values[n] = strtod(end + 1, &end);
        }
        n++;
        p = (*end == ',') ? end + 1 : end;
        if (end == p && *p) return n;
    }
    return n;
}

int main(int argc, char **argv) {
    if (argc != 8) {
        fprintf(stderr, "usage: %s FMU_DIR GUID STOP STEP OUT.csv INPUTS OUTPUTS\n", argv[0]);
        return 2;
    }
    const char *dir = argv[1], *guid = argv[2];
    double stop = atof(argv[3]), h = atof(argv[4]);
    fmi2ValueReference in_vr[64], out_vr[256];
    double in_value[64];
    size_t n_in = parse_list(argv[6], in_vr, in_value, 64);
    size_t n_out = parse_list(argv[7], out_vr, NULL, 256);

    char path[4096], uri[4096];
    snprintf(path, sizeof path, "%s/binaries/linux64/scm.so", dir);
    snprintf(uri, sizeof uri, "file://%s/resources", dir);
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "dlopen %s: %s\n", path, dlerror());
        return 1;
    }
    LOAD(fmi2GetVersion) LOAD(fmi2GetTypesPlatform) LOAD(fmi2Instantiate) LOAD(fmi2FreeInstance)
    LOAD(fmi2SetDebugLogging) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2Terminate) LOAD(fmi2SetReal) LOAD(fmi2GetReal)
    LOAD(fmi2DoStep) LOAD(fmi2GetFMUstate) LOAD(fmi2SetFMUstate) LOAD(fmi2FreeFMUstate)
    LOAD(fmi2SerializedFMUstateSize) LOAD(fmi2SerializeFMUstate) LOAD(fmi2DeSerializeFMUstate)

    if (strcmp(fmi2GetVersion(), fmi2Version) != 0 || strcmp(fmi2GetTypesPlatform(), fmi2TypesPlatform) != 0) {
        fprintf(stderr, "version %s / platform %s\n", fmi2GetVersion(), fmi2GetTypesPlatform());
        return 1;
    }
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("c_host", fmi2CoSimulation, guid, uri, &callbacks, fmi2False, fmi2True);
    if (!c) {
        fprintf(stderr, "fmi2Instantiate failed\n");
        return 1;
    }
    const fmi2String categories[] = {"logEvents", "logStatusError"};
    CHECK(fmi2SetDebugLogging(c, fmi2True, 2, categories));
    CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, stop));
    if (n_in) CHECK(fmi2SetReal(c, in_vr, n_in, in_value));
    CHECK(fmi2EnterInitializationMode(c));
    CHECK(fmi2ExitInitializationMode(c));

    size_t n_steps = (size_t)(stop / h + 0.5), half = n_steps / 2;
    double *rows = calloc((n_steps + 1) * (n_out ? n_out : 1), sizeof(double));
    CHECK(fmi2GetReal(c, out_vr, n_out, rows));
    fmi2FMUstate saved = NULL;
    for (size_t k = 0; k < n_steps; k++) {
        if (k == half) CHECK(fmi2GetFMUstate(c, &saved));
        double t = k * h, next = (k + 1) * h;
        CHECK(fmi2DoStep(c, t, next - t, fmi2True));
        CHECK(fmi2GetReal(c, out_vr, n_out, rows + (k + 1) * n_out));
    }

    /* Serialize the half-time state, read it back, restore it and rerun the second half. */
    size_t size = 0;
    CHECK(fmi2SerializedFMUstateSize(c, saved, &size));
    fmi2Byte *bytes = malloc(size);
    CHECK(fmi2SerializeFMUstate(c, saved, bytes, size));
    fmi2FMUstate restored = NULL;
    CHECK(fmi2DeSerializeFMUstate(c, bytes, size, &restored));
    CHECK(fmi2SetFMUstate(c, restored));
    double *again = malloc(n_out * sizeof(double) + 1);
    for (size_t k = half; k < n_steps; k++) {
        double t = k * h, next = (k + 1) * h;
        CHECK(fmi2DoStep(c, t, next - t, fmi2True));
        CHECK(fmi2GetReal(c, out_vr, n_out, again));
        if (memcmp(again, rows + (k + 1) * n_out, n_out * sizeof(double)) != 0) {
            fprintf(stderr, "the rerun from the deserialized state differs at step %zu\n", k + 1);
            return 1;
        }
    }
    /* Corrupt bytes are refused (fmi2Error), and the instance goes on. */
    bytes[size / 2] ^= 1;
    fmi2FMUstate junk = NULL;
    if (fmi2DeSerializeFMUstate(c, bytes, size, &junk) != fmi2Error || junk != NULL) {
        fprintf(stderr, "corrupt serialized state accepted\n");
        return 1;
    }
    CHECK(fmi2FreeFMUstate(c, &saved));
    CHECK(fmi2FreeFMUstate(c, &restored));
    CHECK(fmi2Terminate(c));
    fmi2FreeInstance(c);
    dlclose(lib);

    FILE *out = fopen(argv[5], "w");
    if (!out) {
        perror(argv[5]);
        return 1;
    }
    for (size_t k = 0; k <= n_steps; k++) {
        fprintf(out, "%.17g", k * h);
        for (size_t i = 0; i < n_out; i++) fprintf(out, ",%.17g", rows[k * n_out + i]);
        fputc('\n', out);
    }
    fclose(out);
    free(rows);
    free(again);
    free(bytes);
    if (bad_format || log_count == 0) {
        fprintf(stderr, "logger: %d messages, bad format: %d\n", log_count, bad_format);
        return 1;
    }
    fprintf(stderr, "%zu steps, %d log messages, state of %zu bytes\n", n_steps, log_count, size);
    return 0;
}
