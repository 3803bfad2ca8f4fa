/* Lamp (tiny PEIS 7): subscribed to key 42 (LightValue) of PEIS 6890 (the
 * plan executor on Astrid, a full PEIS reached through the bridge); sets
 * its dimmer to the level received, reports it and publishes it as its
 * own tuple 45 (LampLevel). */
#include "tiny_app.h"

#define LAMP_ID 7
#define LAMP_SOURCE 6890

uint16_t app_default_id(void) { return LAMP_ID; }

static void on_light(tiny_kernel *k, const tiny_tuple *t, void *user) {
  long level;
  (void)user;
  if (tiny_parse_long(tiny_tuple_data(t), t->data_len, &level) != 0) {
    tiny_port_report("lamp bad-value", (long)t->data_len);
    return;
  }
  if (level < 0) level = 0;
  if (level > 100) level = 100;
  tiny_port_report("lamp light", level);              /* drive the dimmer here */
  (void)tiny_set_long(k, TINY_KEY_LAMP_LEVEL, level); /* tell the ecology */
}

void app_setup(tiny_kernel *k) {
  tiny_key key = tiny_key1(TINY_KEY_LIGHT_VALUE);
  if (tiny_subscribe(k, LAMP_SOURCE, &key, 0, on_light, 0) < 0)
    tiny_port_report("lamp subscribe-failed", 0);
}

void app_loop(tiny_kernel *k, uint32_t now_ms) {
  (void)k;
  (void)now_ms;
}
