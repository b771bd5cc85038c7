/* opencl.h — the OpenCL runtime, loaded at run time (docs/design.md §6): ohm
 * builds without linking it and runs without it, and says clearly when a
 * device was asked for and there is none.
 *
 * The runtime is the ICD loader, libOpenCL.so.1 (Debian's
 * ocl-icd-libopencl1), which finds the vendors' drivers through
 * /etc/OpenCL/vendors or OCL_ICD_VENDORS: PoCL for the CPU in the tests
 * (pocl-opencl-icd), the GPU vendor's on a GPU machine.  OHM_OPENCL_LIBRARY
 * names another loader (a path, or a name for dlopen).
 *
 * ohm_cl holds the loaded library and the entry points ohm calls, named as
 * in the OpenCL 1.2 API without the "cl" prefix; the caller owns it (no
 * process-wide state: dlopen counts its references). */
#ifndef OHM_DEVICE_OPENCL_H
#define OHM_DEVICE_OPENCL_H

#include "base/ohm_error.h"

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>

#ifndef CL_PLATFORM_NOT_FOUND_KHR /* cl_khr_icd: the loader found no driver */
#define CL_PLATFORM_NOT_FOUND_KHR -1001
#endif

typedef struct ohm_cl {
    void *library;
    char path[256]; /* what was loaded */
    cl_int (*GetPlatformIDs)(cl_uint, cl_platform_id *, cl_uint *);
    cl_int (*GetPlatformInfo)(cl_platform_id, cl_platform_info, size_t, void *, size_t *);
    cl_int (*GetDeviceIDs)(cl_platform_id, cl_device_type, cl_uint, cl_device_id *, cl_uint *);
    cl_int (*GetDeviceInfo)(cl_device_id, cl_device_info, size_t, void *, size_t *);
    cl_context (*CreateContext)(const cl_context_properties *, cl_uint, const cl_device_id *,
                                void (*)(const char *, const void *, size_t, void *), void *, cl_int *);
    cl_int (*ReleaseContext)(cl_context);
    cl_command_queue (*CreateCommandQueue)(cl_context, cl_device_id, cl_command_queue_properties, cl_int *);
    cl_int (*ReleaseCommandQueue)(cl_command_queue);
    cl_program (*CreateProgramWithSource)(cl_context, cl_uint, const char **, const size_t *, cl_int *);
    cl_int (*BuildProgram)(cl_program, cl_uint, const cl_device_id *, const char *,
                           void (*)(cl_program, void *), void *);
    cl_int (*GetProgramBuildInfo)(cl_program, cl_device_id, cl_program_build_info, size_t, void *, size_t *);
    cl_int (*ReleaseProgram)(cl_program);
    cl_kernel (*CreateKernel)(cl_program, const char *, cl_int *);
    cl_int (*ReleaseKernel)(cl_kernel);
    cl_int (*SetKernelArg)(cl_kernel, cl_uint, size_t, const void *);
    cl_mem (*CreateBuffer)(cl_context, cl_mem_flags, size_t, void *, cl_int *);
    cl_int (*ReleaseMemObject)(cl_mem);
    cl_int (*EnqueueWriteBuffer)(cl_command_queue, cl_mem, cl_bool, size_t, size_t, const void *, cl_uint,
                                 const cl_event *, cl_event *);
    cl_int (*EnqueueReadBuffer)(cl_command_queue, cl_mem, cl_bool, size_t, size_t, void *, cl_uint,
                                const cl_event *, cl_event *);
    cl_int (*EnqueueNDRangeKernel)(cl_command_queue, cl_kernel, cl_uint, const size_t *, const size_t *,
                                   const size_t *, cl_uint, const cl_event *, cl_event *);
    cl_int (*Finish)(cl_command_queue);
} ohm_cl;

/* Loads the runtime into *cl (OHM_OPENCL_LIBRARY, else libOpenCL.so.1).
 * Without one: OHM_ERR_INVALID and a line that says what to install. */
int ohm_cl_open(ohm_cl *cl, ohm_error *err);
void ohm_cl_close(ohm_cl *cl);

/* "CL_OUT_OF_RESOURCES" for a status code (the number for one it does not know). */
const char *ohm_cl_status(cl_int status, char buf[24]);

#endif
