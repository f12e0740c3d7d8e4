/* A Co-Simulation host for an unzipped SCM FMU, through the FMI 2.0 C ABI alone:
 *
 *   push FMU_DIR GUID INPUT_VR OUTPUT_VR
 *
 * runs 2 s in communication steps of 10 ms, setting the Real input INPUT_VR to 0.1 t at the
 * start of each step, and prints the time and the Real output OUTPUT_VR after each step. For
 * resources/scenes/t_push.xml: the finger's target act_y.ctrl, and the contact force
 * contact.tblock.finger.force.y on the T-block. `scm variables SCENE` prints the GUID and the
 * value references; build and run: docs/fmu.md, "From C". */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include "fmi2Functions.h"

/* FMI's logger takes a printf format and its arguments. */
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    (void)category;
    if (status == fmi2OK) return;
    va_list args;
    va_start(args, message);
    fprintf(stderr, "%s: ", name);
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

/* A value reference from the command line, or exit with a message. */
static fmi2ValueReference value_reference(const char *text) {
    char *end;
    unsigned long vr = strtoul(text, &end, 10);
    if (*text == '\0' || *end != '\0' || vr > 0xffffffffUL) {
        fprintf(stderr, "not a value reference: %s\n", text);
        exit(2);
    }
    return (fmi2ValueReference)vr;
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: %s FMU_DIR GUID INPUT_VR OUTPUT_VR\n", argv[0]);
        return 2;
    }
    char path[4096], uri[4096];
    snprintf(path, sizeof path, "%s/binaries/linux64/scm.so", argv[1]);
    snprintf(uri, sizeof uri, "file://%s/resources", argv[1]);
    void *lib = dlopen(path, RTLD_NOW);
    if (!lib) {
        fprintf(stderr, "%s\n", dlerror());
        return 1;
    }
    fmi2InstantiateTYPE *instantiate = (fmi2InstantiateTYPE *)dlsym(lib, "fmi2Instantiate");
    fmi2SetupExperimentTYPE *setup = (fmi2SetupExperimentTYPE *)dlsym(lib, "fmi2SetupExperiment");
    fmi2EnterInitializationModeTYPE *enter = (fmi2EnterInitializationModeTYPE *)dlsym(lib, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *leave = (fmi2ExitInitializationModeTYPE *)dlsym(lib, "fmi2ExitInitializationMode");
    fmi2SetRealTYPE *set = (fmi2SetRealTYPE *)dlsym(lib, "fmi2SetReal");
    fmi2DoStepTYPE *step = (fmi2DoStepTYPE *)dlsym(lib, "fmi2DoStep");
    fmi2GetRealTYPE *get = (fmi2GetRealTYPE *)dlsym(lib, "fmi2GetReal");
    fmi2TerminateTYPE *terminate = (fmi2TerminateTYPE *)dlsym(lib, "fmi2Terminate");
    fmi2FreeInstanceTYPE *release = (fmi2FreeInstanceTYPE *)dlsym(lib, "fmi2FreeInstance");
    if (!instantiate || !setup || !enter || !leave || !set || !step || !get || !terminate || !release) {
        fprintf(stderr, "%s: not an FMI 2.0 binary (a function is missing)\n", path);
        return 1;
    }
    fmi2ValueReference input = value_reference(argv[3]);
    fmi2ValueReference output = value_reference(argv[4]);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate("push", fmi2CoSimulation, argv[2], uri, &cb, fmi2False, fmi2False);
    if (!c) return 1; /* the logger said why (a wrong GUID, say) */
    int failed = setup(c, fmi2False, 0.0, 0.0, fmi2True, 2.0) > fmi2Warning ||
                 enter(c) > fmi2Warning || leave(c) > fmi2Warning;
    for (int k = 0; k < 200 && !failed; k++) {
        fmi2Real t = k * 0.01, target = 0.1 * t, value;
        failed = set(c, &input, 1, &target) > fmi2Warning || step(c, t, 0.01, fmi2True) > fmi2Warning ||
                 get(c, &output, 1, &value) > fmi2Warning;
        if (!failed) printf("%.2f %.17g\n", (k + 1) * 0.01, value);
    }
    if (!failed) terminate(c);
    release(c);
    if (failed) fprintf(stderr, "the FMU refused a call (its log above says why)\n");
    return failed;
}
