// Test-only include for shaders/test/add.comp (exercises #include resolution from the root).
#ifndef INC_TEST_GLSL
#define INC_TEST_GLSL

// Flat workgroup id for Recorder::dispatch_1d's 2D split of large 1D dispatches.
uint flat_group_id() {
    return gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
}

#endif
