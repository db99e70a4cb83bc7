// Makes Debian's prebuilt ImGui OpenGL3 backend load its GL functions from OSMesa.
//
// Why: libimgui.a's imgui_impl_opengl3.o carries its own loader (gl3w): it dlopen()s libGL.so.1 and fetches every
// function through glXGetProcAddressARB. Under GLVND those are dispatch stubs bound to the current *GLX* context;
// with an OSMesa context current they do nothing, the loader reads GL version 0 and ImGui_ImplOpenGL3_Init fails
// ("Failed to initialize OpenGL loader!"). The GL tests link with -Wl,--wrap=dlsym, so the backend's dlsym calls
// come here, and the one lookup of glXGetProcAddressARB answers with OSMesaGetProcAddress. Only this test
// executable is affected; the viewer itself runs on GLX, where the backend works as shipped.
#include <GL/osmesa.h>
#include <dlfcn.h>

#include <cstring>

extern "C" void* __real_dlsym(void* handle, const char* name);

namespace {

void* osmesa_get_proc(const unsigned char* name) {
  return reinterpret_cast<void*>(OSMesaGetProcAddress(reinterpret_cast<const char*>(name)));
}

}  // namespace

extern "C" void* __wrap_dlsym(void* handle, const char* name) {
  if (name && std::strcmp(name, "glXGetProcAddressARB") == 0) return reinterpret_cast<void*>(&osmesa_get_proc);
  return __real_dlsym(handle, name);
}
