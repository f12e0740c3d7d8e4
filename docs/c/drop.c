/* A Co-Simulation host for an unzipped SCM FMU: drop FMU_DIR GUID VR runs 1 s in steps of
 * 10 ms and prints the time and the Real variable of value reference VR after each step
 * (for sphere_drop, ball.pos.z). Build and run: docs/fmu.md, "From C". */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env; (void)name; (void)status; (void)category; (void)message;
}

int main(int argc, char **argv) {
    if (argc != 4) return 2;
    char path[4096], uri[4096];
    snprintf(path, sizeof path, "%s/binaries/linux64/scm.so", argv[1]);
    snprintf(uri, sizeof uri, "file://%s/resources", argv[1]);
    void *lib = dlopen(path, RTLD_NOW);
    if (!lib) return 1;
    fmi2InstantiateTYPE *instantiate = (fmi2InstantiateTYPE *)dlsym(lib, "fmi2Instantiate");
    fmi2EnterInitializationModeTYPE *enter = (fmi2EnterInitializationModeTYPE *)dlsym(lib, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *leave = (fmi2ExitInitializationModeTYPE *)dlsym(lib, "fmi2ExitInitializationMode");
    fmi2DoStepTYPE *step = (fmi2DoStepTYPE *)dlsym(lib, "fmi2DoStep");
    fmi2GetRealTYPE *get = (fmi2GetRealTYPE *)dlsym(lib, "fmi2GetReal");
    fmi2FreeInstanceTYPE *release = (fmi2FreeInstanceTYPE *)dlsym(lib, "fmi2FreeInstance");
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate("drop", fmi2CoSimulation, argv[2], uri, &cb, fmi2False, fmi2False);
    if (!c || enter(c) != fmi2OK || leave(c) != fmi2OK) return 1;
    fmi2ValueReference vr = (fmi2ValueReference)atoi(argv[3]);
    for (int k = 0; k < 100; k++) {
        fmi2Real z;
        if (step(c, k * 0.01, 0.01, fmi2True) != fmi2OK || get(c, &vr, 1, &z) != fmi2OK) return 1;
        printf("%.2f %.17g\n", (k + 1) * 0.01, z);
    }
    release(c);
    return 0;
}
