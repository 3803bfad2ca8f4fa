// A lamp component: one input (mi-brightness) and one actuator (light).
#include <peis/component.h>

#include <iostream>

int main(int argc, char** argv) {
  peis::Kernel kernel(argc, argv);  // --peis-id, --peis-name, --peis-connect ...
  peis::Component lamp(kernel, "lamp");
  lamp.input("brightness", std::chrono::seconds(5));  // meta tuple mi-brightness
  lamp.actuator("light", [](const std::string& wanted) {
    std::cout << "light -> " << wanted << std::endl;  // drive the dimmer here
    return wanted;                                    // becomes light.currState
  });
  lamp.start();  // status: waiting until mi-brightness points at a fresh value
  kernel.run();  // until kernel.do-quit = yes, SIGINT or SIGTERM
}
