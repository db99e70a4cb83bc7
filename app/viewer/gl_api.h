// The one place the viewer includes OpenGL: core-profile prototypes from Khronos' glcorearb.h. They are resolved
// at link time by whichever GL the executable links: GLVND's libGL (GLX, for the GLFW window) in `pathtracer`,
// libOSMesa in the headless tests. No loader, no GLFW: code including this works with any current 3.3 context.
#pragma once
#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
