// Entry point: wire up every panel of the dashboard.

import { initDrive } from "./drive.js";
import { initFall } from "./fall.js";
import { initGhost } from "./ghost.js";
import { initMotion } from "./motion.js";
import { initParams, refreshParams } from "./params.js";
import { initPaths } from "./paths.js";
import { initPresets } from "./presets.js";
import { initReplay } from "./replay.js";
import { initRobot } from "./robot.js";
import { initScope } from "./scope-panel.js";
import { initSensors } from "./sensors.js";
import { initServoLoad } from "./servo-load.js";
import { initStatus } from "./status.js";
import { initTransfer } from "./transfer.js";
import { initTune } from "./tune.js";
import { initViser } from "./viser.js";
import { initWorld } from "./world.js";

initStatus();
initDrive();
initViser();
initScope();
initPaths();
initParams();
initMotion();
initFall();
initPresets();
initTransfer();
initServoLoad();
initSensors();
initGhost();
initReplay();
initWorld();
initRobot();
initTune();
refreshParams();
