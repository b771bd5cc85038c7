/* opencl.c — see opencl.h. */
#include "device/opencl.h"

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The runtime's entry point `name` into `slot` (a function pointer: POSIX's
 * dlsym guarantees the conversion from a data pointer). */
static int bind_entry(ohm_cl *cl, void *slot, const char *name, ohm_error *err)
{
    void *f = dlsym(cl->library, name);
    if (!f) return ohm_fail(err, OHM_ERR_INVALID, "OpenCL runtime %s lacks %s (it is not OpenCL 1.2)", cl->path, name);
    memcpy(slot, &f, sizeof f);
    return OHM_OK;
}

int ohm_cl_open(ohm_cl *cl, ohm_error *err)
{
    memset(cl, 0, sizeof *cl);
    const char *env = getenv("OHM_OPENCL_LIBRARY");
    const char *path = env && *env ? env : "libOpenCL.so.1";
    snprintf(cl->path, sizeof cl->path, "%s", path);
    cl->library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!cl->library)
        return ohm_fail(err, OHM_ERR_INVALID,
                        "no OpenCL runtime: %s cannot be loaded (%s); install Debian's ocl-icd-libopencl1 and a "
                        "device's driver (pocl-opencl-icd for the CPU, or the GPU vendor's OpenCL ICD)",
                        path, dlerror());
    struct {
        void *slot;
        const char *name;
    } entries[] = {
        {&cl->GetPlatformIDs, "clGetPlatformIDs"},
        {&cl->GetPlatformInfo, "clGetPlatformInfo"},
        {&cl->GetDeviceIDs, "clGetDeviceIDs"},
        {&cl->GetDeviceInfo, "clGetDeviceInfo"},
        {&cl->CreateContext, "clCreateContext"},
        {&cl->ReleaseContext, "clReleaseContext"},
        {&cl->CreateCommandQueue, "clCreateCommandQueue"},
        {&cl->ReleaseCommandQueue, "clReleaseCommandQueue"},
        {&cl->CreateProgramWithSource, "clCreateProgramWithSource"},
        {&cl->BuildProgram, "clBuildProgram"},
        {&cl->GetProgramBuildInfo, "clGetProgramBuildInfo"},
        {&cl->ReleaseProgram, "clReleaseProgram"},
        {&cl->CreateKernel, "clCreateKernel"},
        {&cl->ReleaseKernel, "clReleaseKernel"},
        {&cl->SetKernelArg, "clSetKernelArg"},
        {&cl->CreateBuffer, "clCreateBuffer"},
        {&cl->ReleaseMemObject, "clReleaseMemObject"},
        {&cl->EnqueueWriteBuffer, "clEnqueueWriteBuffer"},
        {&cl->EnqueueReadBuffer, "clEnqueueReadBuffer"},
        {&cl->EnqueueNDRangeKernel, "clEnqueueNDRangeKernel"},
        {&cl->Finish, "clFinish"},
    };
    for (size_t i = 0; i < sizeof entries / sizeof *entries; ++i) {
        int rc = bind_entry(cl, entries[i].slot, entries[i].name, err);
        if (rc) {
            ohm_cl_close(cl);
            return rc;
        }
    }
    return OHM_OK;
}

void ohm_cl_close(ohm_cl *cl)
{
    if (cl->library) dlclose(cl->library);
    memset(cl, 0, sizeof *cl);
}

const char *ohm_cl_status(cl_int status, char buf[24])
{
    static const struct {
        cl_int code;
        const char *name;
    } names[] = {
        {CL_SUCCESS, "CL_SUCCESS"},
        {CL_DEVICE_NOT_FOUND, "CL_DEVICE_NOT_FOUND"},
        {CL_DEVICE_NOT_AVAILABLE, "CL_DEVICE_NOT_AVAILABLE"},
        {CL_COMPILER_NOT_AVAILABLE, "CL_COMPILER_NOT_AVAILABLE"},
        {CL_MEM_OBJECT_ALLOCATION_FAILURE, "CL_MEM_OBJECT_ALLOCATION_FAILURE"},
        {CL_OUT_OF_RESOURCES, "CL_OUT_OF_RESOURCES"},
        {CL_OUT_OF_HOST_MEMORY, "CL_OUT_OF_HOST_MEMORY"},
        {CL_BUILD_PROGRAM_FAILURE, "CL_BUILD_PROGRAM_FAILURE"},
        {CL_INVALID_VALUE, "CL_INVALID_VALUE"},
        {CL_INVALID_PLATFORM, "CL_INVALID_PLATFORM"},
        {CL_INVALID_DEVICE, "CL_INVALID_DEVICE"},
        {CL_INVALID_BUFFER_SIZE, "CL_INVALID_BUFFER_SIZE"},
        {CL_INVALID_KERNEL_ARGS, "CL_INVALID_KERNEL_ARGS"},
        {CL_INVALID_WORK_GROUP_SIZE, "CL_INVALID_WORK_GROUP_SIZE"},
        {CL_PLATFORM_NOT_FOUND_KHR, "CL_PLATFORM_NOT_FOUND_KHR (no OpenCL driver is installed)"},
    };
    for (size_t i = 0; i < sizeof names / sizeof *names; ++i)
        if (names[i].code == status) return names[i].name;
    snprintf(buf, 24, "OpenCL error %d", (int)status);
    return buf;
}
