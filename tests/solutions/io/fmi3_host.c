/* A minimal FMI 3.0 co-simulation importer, in C as simulation tools are: it loads an FMU's binary, instantiates
   it, initializes it, takes STEPS communication steps of H seconds and prints one output at the end.

   usage: fmi3_host BINARY RESOURCES TOKEN VALUE_REFERENCE STEPS H
   Built by tests/solutions/io/test_fmu.py with the FMI 3.0 headers that fmpy ships (fmpy/c-code). */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "fmi3Functions.h"

static void logger(fmi3InstanceEnvironment environment, fmi3Status status, fmi3String category, fmi3String message) {
    fprintf(stderr, "%s: %s\n", category, message);
}

int main(int argc, char **argv) {
    if (argc != 7) {
        fprintf(stderr, "usage: fmi3_host BINARY RESOURCES TOKEN VALUE_REFERENCE STEPS H\n");
        return 2;
    }
    fmi3ValueReference reference = (fmi3ValueReference)atoi(argv[4]);
    int steps = atoi(argv[5]);
    double h = atof(argv[6]);
    void *library = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 1;
    }
    fmi3InstantiateCoSimulationTYPE *instantiate = dlsym(library, "fmi3InstantiateCoSimulation");
    fmi3EnterInitializationModeTYPE *enter = dlsym(library, "fmi3EnterInitializationMode");
    fmi3ExitInitializationModeTYPE *leave = dlsym(library, "fmi3ExitInitializationMode");
    fmi3DoStepTYPE *step = dlsym(library, "fmi3DoStep");
    fmi3GetFloat64TYPE *get = dlsym(library, "fmi3GetFloat64");
    fmi3TerminateTYPE *terminate = dlsym(library, "fmi3Terminate");
    fmi3FreeInstanceTYPE *release = dlsym(library, "fmi3FreeInstance");
    fmi3Instance instance = instantiate("host", argv[3], argv[2], fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0,
                                        NULL, logger, NULL);
    if (!instance || enter(instance, fmi3False, 0.0, 0.0, fmi3True, steps * h) > fmi3Warning ||
        leave(instance) > fmi3Warning) {
        fprintf(stderr, "the FMU did not initialize\n");
        return 1;
    }
    fmi3Boolean event, end, early;
    fmi3Float64 reached, value;
    for (int k = 0; k < steps; k++) {
        if (step(instance, k * h, h, fmi3True, &event, &end, &early, &reached) > fmi3Warning) {
            fprintf(stderr, "step %d failed\n", k);
            return 1;
        }
    }
    get(instance, &reference, 1, &value, 1);
    printf("%.17g\n", value);
    terminate(instance);
    release(instance);
    fflush(stdout);
    /* _exit, not return: at the library's unload (exit's destructors) pythonfmu3's loader finalizes the interpreter
       it started, which crashes once numpy and scipy were imported (as a pythonfmu3 FMU that only imports them
       does too); the simulation is over by then. */
    _exit(0);
}
