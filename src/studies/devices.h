/* devices.h — `ohm devices`: the OpenCL platforms and devices this machine
 * has (docs/devices.md), each with its memory, double precision, and its memory
 * bandwidth measured by a triad kernel that is checked element by element,
 * so that a listed device is known to build and run ohm's kernels. */
#ifndef OHM_STUDIES_DEVICES_H
#define OHM_STUDIES_DEVICES_H

/* argv after "devices"; the process's exit code (0 listed, 1 no runtime or
 * no device, or a device failed its kernel; 2 bad usage). */
int ohm_devices_main(int argc, char **argv);

#endif
