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
#include <stdio.h>
#include <stdlib.h>
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    (void)category;
    if (status != fmi2OK) fprintf(stderr, "%s: %s\n", name, message);
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
    fmi2EnterInitializationModeTYPE *enter = (fmi2EnterInitializationModeTYPE *)dlsym(lib, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *leave = (fmi2ExitInitializationModeTYPE *)dlsym(lib, "fmi2ExitInitializationMode");
    fmi2SetRealTYPE *set = (fmi2SetRealTYPE *)dlsym(lib, "fmi2SetReal");
    fmi2DoStepTYPE *step = (fmi2DoStepTYPE *)dlsym(lib, "fmi2DoStep");
    fmi2GetRealTYPE *get = (fmi2GetRealTYPE *)dlsym(lib, "fmi2GetReal");
    fmi2FreeInstanceTYPE *release = (fmi2FreeInstanceTYPE *)dlsym(lib, "fmi2FreeInstance");
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate("push", fmi2CoSimulation, argv[2], uri, &cb, fmi2False, fmi2False);
    if (!c || enter(c) != fmi2OK || leave(c) != fmi2OK) return 1;
    fmi2ValueReference input = (fmi2ValueReference)atoi(argv[3]);
    fmi2ValueReference output = (fmi2ValueReference)atoi(argv[4]);
    for (int k = 0; k < 200; k++) {
        fmi2Real t = k * 0.01, target = 0.1 * t, value;
        if (set(c, &input, 1, &target) != fmi2OK || step(c, t, 0.01, fmi2True) != fmi2OK ||
            get(c, &output, 1, &value) != fmi2OK)
            return 1;
        printf("%.2f %.17g\n", (k + 1) * 0.01, value);
    }
    release(c);
    return 0;
}
